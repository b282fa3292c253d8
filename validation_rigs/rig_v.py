"""Rig V: an independent validation model of the CFETR CMOR joint-4 test bench.

Written from the paper (shared/seeds/cmor-sghmc-paper.txt) and the shared docs only, with its own
modelling choices, to score a sim-to-real diagnosis blind. All quantities SI (angles rad, torques
N·m, pressures Pa) except temperatures (°C).

Data sheet
==========

Machine (nominal; each campaign draws a small spread from the seed)
------------------------------------------------------------------
* Output body, the paper's Eq. 4 plus the load (rig.md):
  ``I·q̈ = T − τ_L − g·(mr_x·sin q + mr_y·cos q) − F_f + τ_2 + τ_d``
  with Table 3 (least squares): I = 6685.166 kg·m², mr_x = 20.779 kg·m, mr_y = −34.543 kg·m,
  f_v = 8683.272 N·m·s/rad, f_c = 2352.660 N·m; g = 9.81 m/s². Campaign spread (normal, clipped at
  ±2.5 sd): I 0.5 %, mr_x 3 %, mr_y 3 %, f_v 0.2 %, f_c 0.3 %. ``τ_2`` (second resonance) and
  ``τ_d`` (periodic disturbance) are zero without effects.
* Output friction ``F_f``: elasto-plastic presliding model (Dupont, Hayward, Armstrong & Altpeter
  2002). Bristle state z [rad]: ``ż = v·(1 − α(z, v)·|z|/z_ss(v))``, ``z_ss = F_ss(v)/σ0``;
  α = 0 while |z| ≤ z_ba = 0.7·z_ss or sgn z ≠ sgn v (purely elastic presliding),
  α = ½ sin(π(|z| − (z_ss + z_ba)/2)/(z_ss − z_ba)) + ½ between, 1 beyond z_ss.
  ``F_f = σ0·z + σ1·ż + f_v(T_oil)·v`` with σ0 = f_c/3e-5 rad (≈7.8e7 N·m/rad, breakaway
  displacement ≈ 2e-5 rad), σ1 = 1.5e5 N·m·s/rad. Steady sliding: ż = 0, |z| = z_ss, so
  ``F_f = F_ss(v)·sgn v + f_v·v`` = Eq. 4's ``f_c·sgn q̇ + f_v·q̇`` without effects
  (F_ss = f_c; the Stribeck effect raises F_ss at low speed).
* Oil viscosity (Vogel law) ``μ(T)/μ(T_ref) = exp(B·(1/(T + C) − 1/(T_ref + C)))``, B = 1000 K,
  C = 120 K, T_ref = 30 °C; it sets a fraction φ_oil = 0.2 of the viscous friction:
  ``f_v(T) = f_v·(1 − φ_oil + φ_oil·μ(T)/μ(T_ref))`` (Table 3 exactly at 30 °C; +22 % at 15 °C,
  −13 % at 60 °C, i.e. ±30–60 N·m at 3000 r/min).
* Thermal node (one lumped oil/gearbox node): ``C_th·Ṫ_oil = P_fric + P_mesh + P_churn −
  hA·(T_oil − T_amb)``; C_th = 2e5 J/K, hA = 60 W/K, T_amb = min(T_start, 22 °C),
  P_fric = |F_f·q̇|, P_mesh = 0.03·|T·q̇|, P_churn = 0.05·(μ/μ_ref)·ω_b² W.
  Motor windings: ``C_w·Ṫ_w = R·i² − (T_w − T_oil)/R_th``, C_w = 800 J/K, R = 0.8 Ω, R_th = 0.6 K/W.
* Drive train: three motors (J_m = 5e-4 kg·m², k_t = 1.0 N·m/A, current limit 12 A, viscous 1e-4 N·m·s/rad + Coulomb 0.05·tanh(ω/0.5) N·m),
  each through its own pinion into one bull gear (first stage n1 = 11, mesh/coupling stiffness
  k1 = 200·n1² N·m/rad referred to the bull gear, damping 0.05·n1² N·m·s/rad; bull gear
  J_b = 1.0 kg·m², viscous 0.02 N·m·s/rad), then the main stage (n2 = 1000) to the output:
  N = n1·n2 = 11000. States: mesh twists e_k = θ_k/n1 − φ, main twist Δ2 = φ/n2 − q.
* Main-stage transmission law (stiffer centre, then linear):
  ``T = k_lin·δ + T_s·tanh(δ/θ_s) + c_2·Δ̇2·dδ/dΔ2 + T_h``, δ = Δ2 (+ effects), k_lin = 1.3e7
  N·m/rad, T_s = 5e3 N·m, θ_s = 2e-4 rad (centre stiffness 3.8e7 N·m/rad; about 0.51° twist at
  120 kN·m), c_2 = 6e4 N·m·s/rad. Campaign spread: k_lin 3 %, T_s 5 %.
  True twist (truth "twist") = mean motor angle / N − q; it includes the (tiny) first-stage
  compliance.
* Speed loops: discrete PI at the inner-step rate (≈ 2 kHz, zero-order hold), speed from the
  quantised motor-1 encoder (2^20 counts/rev) by backward difference. Master–slave: motor 1 is
  speed-controlled (Kp = 0.12 A·s/rad, Ki = 2.4 A/rad), motors 2 and 3 receive its current
  command times (1 + mismatch), mismatch uniform in ±1.5 % per campaign, all clipped at ±12 A;
  anti-windup by clamping.
  Scheme 3 adds an outer position loop on u (1.5 1/s) to the Fourier velocity feed-forward.
* Loading device: hydraulic rotary vane actuator on a loading shaft (k_ls = 2e7 N·m/rad,
  c_ls = 2e4 N·m·s/rad; τ_L = k_ls·(q − ψ) + c_ls·(q̇ − ψ̇) is what the load cell reads);
  ``J_a·ψ̈ = τ_L − D_v·(p_a − p_b) − b_a·ψ̇`` (J_a = 80 kg·m², D_v = 1e-2 m³/rad, b_a = 2e3);
  chambers ``ṗ_a = β/V_a·(Q_a + D_v·ψ̇ − C_L·(p_a − p_b))``, ``ṗ_b = β/V_b·(Q_b − D_v·ψ̇ +
  C_L·(p_a − p_b))``, V_a,b = V0 ∓ D_v·ψ, V0 = 0.028 m³, β = 1.4e9 Pa (spread 5 %),
  C_L = 2e-12 m³/(s·Pa), supply 21 MPa, tank 0.3 MPa; critical-centre four-way servo valve
  ``Q = K_v·x·ssqrt(Δp)``, K_v = 3.8e-7 m³/(s·√Pa), spool second order
  ``ẍ_v = ω_v²(i_v − x_v) − 2ζ_v ω_v ẋ_v`` (ω_v = 2π·50 rad/s, ζ_v = 0.7).
  Torque controller (discrete, ~1 kHz, ZOH): PI on (τ_cmd − τ_L) (Kp = 3e-5 /N·m,
  Ki = 1.5e-4 /(N·m·s)) plus flow feed-forward −D_v·ψ̇/(K_v·√Δp_valve); command clipped to ±1.
* Integrator: TR-BDF2 (γ = 2 − √2; trapezoidal stage to t + γh, BDF2 stage to t + h) with a
  simplified Newton iteration on each stage (the two stages share the matrix I − (γ/2)·h·J;
  J by forward differences, refreshed every 40 steps or when Newton stalls), fixed inner step
  h = T_s/m ≤ 0.5 ms (m = ceil(T_s/0.5 ms)); the stiffest modes (motor-pinion ≈ 690 rad/s,
  loading shaft ≈ 500 rad/s, spool 314 rad/s) have ω·h ≤ 0.35. numba-compiled.

Schemes (paper section II-B)
----------------------------
1. 70 s: motors ramp to ``direction·motor_speed_rpm`` in 1 s; idle to 4 s; the dynamometer set
   point ramps 0 → 120 kN·m over 30 s (``load``), holds 2 s (``hold``), ramps to 0 over 30 s
   (``unload``), idle to 70 s.
2. 55 s: same speed; twelve steps of 10 kN·m (1 s ramp ``load`` + 2 s pause ``hold``) from 4 s to
   40 s, unload to 0 over 12 s, idle to 55 s.
3. Eq. 12, five harmonics, period 20 s, ``periods`` periods, ``excite``; Σa_l = 0 and
   Σl·b_l = 0 so the trajectory starts at rest (q = 0, q̇ = 0, q̈ = 0); peak output speed 90 % of
   the 3000 r/min limit; dynamometer set point 0. Mirrored for direction −1.
A hydraulic cylinder holds a bending moment of 50 kN·m and a shear of 30 kN (first-order
approach, 0.8 s) in every scheme.

Sensors (stated; written into meta["sensors"])
-----------------------------------------------
q: output encoder, quantised at encoder_res_deg; u: motor-1 encoder / N, quantised at
2π/(counts·N); torque: transmitted torque + N(0, torque_noise), ADC step torque_adc_step,
pure lag torque_lag_s; torque_load: load cell + N(0, load_noise), ADC step; i_m1..3: current
+ N(0, current_noise), 1 mA step; w_m1..3: drive speed estimate + N(0, 0.01 rad/s); temp_joint,
temp_m1..3: + N(0, temp_noise), 0.1 °C step; p_hyd (chamber A), m_bend, f_shear; torsion = q − u
of the readings; torque_cmd; phase.

Unstated imperfections (params["unstated"]; drawn per campaign)
---------------------------------------------------------------
* bending-moment crosstalk into the torque gauge: c_x ∈ U(0.002, 0.004) × m_bend (100–200 N·m)
  plus a zero offset N(0, 40) N·m  → vocabulary ``torque_offset``;
* an extra 2 ms pure lag of the torque reading (fieldbus cycle) → ``time_delay``;
* the nominal oil-viscosity law above moves f_v away from Table 3 off 30 °C →
  ``temperature_friction``;
* output-encoder interpolation error: amplitude U(0.1, 0.25)·resolution, 9000 periods/rev
  (not in the vocabulary);
* load-cell gain error 1 + N(0, 0.002) (not in the vocabulary).

Effects at scale s (every one ≈ linear in s for small s; 0 ≤ s ≤ SCALE_MAX = 10)
------------------------------------------------------------------------------
* stribeck (raises F_ss): ``F_ss = F_c + 400·s·shape(|v|/v_s)``, v_s = 0.004 rad/s; forms
  exponential exp(−x), gaussian exp(−x²), lorentzian 1/(1+x²), sech 1/cosh(x).
* load_dependent_friction (|T| the transmitted torque): coulomb_linear F_c += 0.004·s·|T|;
  coulomb_viscous (F_c, f_v) × (1 + 0.15·s·|T|/120 kN·m); power_flow F_c += s·|T|·(0.0045
  driving, 0.0015 back-driving; smooth switch on T·v over 50 W); quadratic F_c +=
  450·s·(T/120 kN·m)².
* temperature_friction (g = exp(−(T_oil − 15)/25)): viscous_multiplicative f_v ×(1 + s·g);
  coulomb_additive F_c += 250·s·g; coulomb_viscous_multiplicative (F_c, f_v) ×(1 + 0.12·s·g);
  vogel_viscous_additive f_v += 2000·s·(exp(600·(1/(T+110) − 1/170)) − 1) (0 at 60 °C).
* gear_ripple (mesh torque ripple acting on the output body, subtracted from its torque balance,
  A = 300·s N·m): output_fundamental A·sin(36q); output_harmonics A·(0.7 sin 36q +
  0.4 sin(72q + 0.5) + 0.25 sin(108q + 1.1)); motor_angle 0.4·A·sin(2·θ_m) (2 cycles per motor
  revolution, θ_m the mean motor angle; 10 Hz at 300 r/min, near the output mode, so amplified);
  intermediate_shaft A·(0.8 sin φ + 0.4 sin(2φ + 0.7)) (φ the bull-gear angle);
  load_modulated A·(0.3 + 0.7·|T|/120 kN·m)·sin(36q).
* torque_offset (torque reading only): constant +300·s; linear_drift +300·s·t/60;
  exponential_settling +400·s·(1 − exp(−t/15)); temperature_coupled +300·s·(1 + 0.03·(T_oil − 25)).
* time_delay: pure_torque torque lags 0.05·s s; first_order_torque first-order lag τ = 0.05·s s;
  encoder_q q reading lags 0.05·s s (linear interpolation on the sample grid).
* hysteresis (T_h added to T, H = 400·s N·m, δ_h = 5e-5 rad, x driven by Δ̇2):
  bouc_wen_n1 ẋ = (Δ̇ − ½|Δ̇|x − ½Δ̇|x|)/δ_h; bouc_wen_n2 ẋ = (Δ̇ − ½|Δ̇||x|x − ½Δ̇x²)/δ_h;
  dahl ẋ = Δ̇/δ_h·(1 − x·tanh(Δ̇/1e-6)); T_h = H·x; windup_loss: bouc_wen_n1 plus
  H·(Δ2/9e-3)·|Δ2/9e-3|.
* backlash (half-gap b = 2.5e-5·s rad ≈ 325·s N·m of twist): sharp dead zone; smooth_sqrt (two
  hyperbolas, ε = 0.3b); smooth_tanh δ = x − b·tanh(x/b); load_closing δ = x −
  b·tanh(x/b)/(1 + (x/(10b))²) (the gap closes under preload). Mesh damping follows dδ/dx.
* asymmetric_friction (σ = tanh(v/1e-5)): coulomb F_c += 150·s·σ; viscous f_v ×(1 + 0.8·s)^σ;
  coulomb_viscous F_c ×(1 + 0.06·s)^σ, f_v ×(1 + 0.4·s)^σ; offset F_f += 200·s (a constant
  non-gravity torque).
* periodic_disturbance (torque on the output, A = 300·s N·m): single_tone A·sin(2π·1.3t);
  two_tone A·(0.7 sin(2π·1.3t) + 0.5 sin(2π·3.1t + 0.4)); am_tone
  A·(0.6 + 0.4 sin(2π·0.05t))·sin(2π·2.2t).
* position_stiffness (k_lin × factor, floored at 0.3; seen in the twist, ≈ 2 encoder steps at
  full load): cosine 1 + 0.04·s·cos 2q; linear 1 + 0.1·s·q; bump
  1 + 0.1·s·exp(−((q − 0.1)/0.15)²).
* sensor_drift: torque_gain_drift torque reading ×(1 + 0.004·s·t/60); encoder_zero_drift q
  reading + 2e-4·s·t/60 rad; load_cell_drift torque_load reading + 300·s·t/60.
* second_resonance (a body J2 on a spring, τ_2 = k2·(q2 − x_a) + c2·(q̇2 − ẋ_a), k2 = J2·ω²,
  c2 = 2ζ·J2·ω): output_link J2 = 2000·s kg·m², 6 Hz, ζ 0.02 on the output (x_a = q);
  output_link_stiff J2 = 2000·s, 14 Hz, ζ 0.01 on the output; bull_gear J2 = 2e5·s
  (output-referred), 3 Hz, ζ 0.05 on the bull gear (x_a = φ/n2, reaction through the main stage).
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, fields
from typing import Any

import numpy as np
import pandas as pd
from numba import njit

RIG_NAME = "rig_v"
REDUCTION = 11000.0
SEED_IS_CAMPAIGN = True
SCALE_MAX = 10.0

EFFECT_FORMS: dict[str, tuple[str, ...]] = {
    "stribeck": ("exponential", "gaussian", "lorentzian", "sech"),
    "load_dependent_friction": ("coulomb_linear", "coulomb_viscous", "power_flow", "quadratic"),
    "temperature_friction": ("viscous_multiplicative", "coulomb_additive",
                             "coulomb_viscous_multiplicative", "vogel_viscous_additive"),
    "gear_ripple": ("output_fundamental", "output_harmonics", "motor_angle", "intermediate_shaft",
                    "load_modulated"),
    "torque_offset": ("constant", "linear_drift", "exponential_settling", "temperature_coupled"),
    "time_delay": ("pure_torque", "first_order_torque", "encoder_q"),
    "hysteresis": ("bouc_wen_n1", "bouc_wen_n2", "dahl", "windup_loss"),
    "backlash": ("sharp", "smooth_sqrt", "smooth_tanh", "load_closing"),
    "asymmetric_friction": ("coulomb", "viscous", "coulomb_viscous", "offset"),
    "periodic_disturbance": ("single_tone", "two_tone", "am_tone"),
    "position_stiffness": ("cosine", "linear", "bump"),
    "sensor_drift": ("torque_gain_drift", "encoder_zero_drift", "load_cell_drift"),
    "second_resonance": ("output_link", "output_link_stiff", "bull_gear"),
}
OUT_OF_VOCABULARY = ("periodic_disturbance", "position_stiffness", "sensor_drift",
                     "second_resonance")
UNSTATED_VOCABULARY: dict[str, str] = {
    "torque_offset": "bending-moment crosstalk into the torque gauge (0.2-0.4 % of the 50 kN·m "
                     "bending moment, 100-200 N·m) plus a zero offset of a few tens of N·m",
    "time_delay": "the torque reading lags a further 2 ms (fieldbus cycle) beyond its stated lag",
    "temperature_friction": "oil viscosity (Vogel law) sets 20 % of the viscous friction: f_v "
                            "equals Table 3 at 30 °C only (+22 % at 15 °C, -13 % at 60 °C)",
}

_EFFECT_NAMES = tuple(EFFECT_FORMS)
_EFFECT_INDEX = {n: i for i, n in enumerate(_EFFECT_NAMES)}
_SENSOR_ONLY = ("torque_offset", "time_delay", "sensor_drift")

TABLE3 = {"I": 6685.166, "mr_x": 20.779, "mr_y": -34.543, "f_v": 8683.272, "f_c": 2352.660}
"""The paper's Table 3 least-squares values of Eq. 4 (SI)."""
G = 9.81
T_REF_C = 30.0
RATED_LOAD = 120e3
OUT_SPEED_MAX = 3000.0 * 2.0 * math.pi / 60.0 / REDUCTION
FOURIER_PERIOD = 20.0
_FA = np.array([0.6, -0.2, -0.3, 0.1, -0.2])
_FB = np.array([0.4, 0.3, -0.2, 0.1, -0.16])

# effect indices (numba reads module ints as constants)
E_STRIB, E_LOAD, E_TEMP, E_RIPPLE, E_TOFF, E_DELAY, E_HYST, E_BACK, E_ASYM, E_PER, E_POS, \
    E_DRIFT, E_RES2 = range(13)

# state indices
S_E1, S_E2, S_E3, S_D2, S_Q, S_W1, S_W2, S_W3, S_WB, S_QD, S_Z, S_S, S_PSID, S_PA, S_PB, \
    S_XV, S_XVD, S_TOIL, S_TW1, S_TW2, S_TW3, S_HX, S_Q2, S_Q2D = range(24)
NS = 24

# parameter indices
(P_I, P_MRX, P_MRY, P_FV, P_FC, P_N1, P_N2, P_JM, P_JB, P_K1, P_C1, P_BM, P_FCM, P_BB,
 P_KLIN, P_TS, P_THS, P_C2, P_SIG0, P_SIG1, P_KLS, P_CLS, P_JA, P_BA, P_DV, P_BETA, P_V0, P_CL,
 P_KV, P_PS, P_PT, P_WV, P_ZV, P_CTH, P_HA, P_TAMB, P_PHIOIL, P_CCH, P_RW, P_CW, P_RTH, P_KT,
 P_MIS2, P_MIS3, P_IMAX, P_KP, P_KI, P_KPOS, P_HKP, P_HKI, P_NPAR) = range(51)

# auxiliary outputs of the right-hand side
A_T, A_TL, A_FF, A_TWIST, A_THETA1, A_G = range(6)
NAUX = 6

# record columns
R_T, R_TL, R_FF, R_TWIST, R_TH1, R_I1, R_I2, R_I3, R_IV, R_TCMD, R_WREF = range(NS, NS + 11)
NREC = NS + 11


# ------------------------------------------------------------------ numba kernel ---------------

@njit(cache=True)
def _vogel_ratio(temp: float) -> float:
    return math.exp(1000.0 * (1.0 / (temp + 120.0) - 1.0 / (T_REF_C + 120.0)))


@njit(cache=True)
def _deadzone(x: float, form: int, b: float) -> float:
    if form == 0:
        if x > b:
            return x - b
        if x < -b:
            return x + b
        return 0.0
    if form == 1:
        e = 0.3 * b
        return 0.5 * ((x - b) + math.sqrt((x - b) ** 2 + e * e)) + \
            0.5 * ((x + b) - math.sqrt((x + b) ** 2 + e * e))
    if form == 2:
        return x - b * math.tanh(x / b)
    return x - b * math.tanh(x / b) / (1.0 + (x / (10.0 * b)) ** 2)


@njit(cache=True)
def _rhs(y, t, P, E, u, dy, aux):
    """dy = f(y, t) for held inputs u = [i1, i2, i3, valve command]; aux gets T, τ_L, F_f, ..."""
    n1 = P[P_N1]
    n2 = P[P_N2]
    q = y[S_Q]
    v = y[S_QD]
    wb = y[S_WB]
    phi = n2 * (y[S_D2] + q)
    # ---- first stage meshes (bull-gear units) --------------------------------------------
    msum = 0.0
    mk = np.empty(3)
    for k in range(3):
        mk[k] = P[P_K1] * y[S_E1 + k] + P[P_C1] * (y[S_W1 + k] / n1 - wb)
        msum += mk[k]
    theta_m = n1 * ((y[S_E1] + y[S_E2] + y[S_E3]) / 3.0 + phi)
    # ---- main stage ------------------------------------------------------------------------
    d2 = y[S_D2]
    d2dot = wb / n2 - v
    x = d2
    delta = x
    ddelta = 1.0
    if E[E_BACK, 1] > 0.0:
        f = int(E[E_BACK, 0])
        b = 2.5e-5 * E[E_BACK, 1]
        delta = _deadzone(x, f, b)
        hb = 1e-3 * b
        ddelta = (_deadzone(x + hb, f, b) - _deadzone(x - hb, f, b)) / (2.0 * hb)
    klin = P[P_KLIN]
    if E[E_POS, 1] > 0.0:
        f = int(E[E_POS, 0])
        s = E[E_POS, 1]
        if f == 0:
            fac = 1.0 + 0.04 * s * math.cos(2.0 * q)
        elif f == 1:
            fac = 1.0 + 0.1 * s * q
        else:
            fac = 1.0 + 0.1 * s * math.exp(-((q - 0.1) / 0.15) ** 2)
        klin *= max(fac, 0.3)
    T = klin * delta + P[P_TS] * math.tanh(delta / P[P_THS]) + P[P_C2] * d2dot * ddelta
    hx = y[S_HX]
    dhx = 0.0
    if E[E_HYST, 1] > 0.0:
        f = int(E[E_HYST, 0])
        H = 400.0 * E[E_HYST, 1]
        dh = 5e-5
        if f == 0 or f == 3:
            dhx = (d2dot - 0.5 * abs(d2dot) * hx - 0.5 * d2dot * abs(hx)) / dh
        elif f == 1:
            dhx = (d2dot - 0.5 * abs(d2dot) * abs(hx) * hx - 0.5 * d2dot * hx * hx) / dh
        else:
            dhx = d2dot / dh * (1.0 - hx * math.tanh(d2dot / 1e-6))
        T += H * hx
        if f == 3:
            r = d2 / 9e-3
            T += H * r * abs(r)
    # ---- loading shaft and second resonance ---------------------------------------------
    tl = P[P_KLS] * y[S_S] + P[P_CLS] * (v - y[S_PSID])
    tau2 = 0.0
    tau2_bull = 0.0
    dq2d = 0.0
    if E[E_RES2, 1] > 0.0:
        f = int(E[E_RES2, 0])
        if f == 0:
            fr, zr, j2 = 6.0, 0.02, 2000.0 * E[E_RES2, 1]
        elif f == 1:
            fr, zr, j2 = 14.0, 0.01, 2000.0 * E[E_RES2, 1]
        else:
            fr, zr, j2 = 3.0, 0.05, 2e5 * E[E_RES2, 1]
        wr = 2.0 * math.pi * fr
        k2 = j2 * wr * wr
        c2 = 2.0 * zr * j2 * wr
        if f == 2:
            tq = k2 * (y[S_Q2] - phi / n2) + c2 * (y[S_Q2D] - wb / n2)
            tau2_bull = tq
        else:
            tq = k2 * (y[S_Q2] - q) + c2 * (y[S_Q2D] - v)
            tau2 = tq
        dq2d = -tq / j2
    # ---- friction (elasto-plastic) ------------------------------------------------------
    temp = y[S_TOIL]
    ratio = _vogel_ratio(temp)
    fv = P[P_FV] * (1.0 - P[P_PHIOIL] + P[P_PHIOIL] * ratio)
    fc = P[P_FC]
    extra = 0.0
    if E[E_TEMP, 1] > 0.0:
        f = int(E[E_TEMP, 0])
        s = E[E_TEMP, 1]
        g = math.exp(-(temp - 15.0) / 25.0)
        if f == 0:
            fv *= 1.0 + s * g
        elif f == 1:
            fc += 250.0 * s * g
        elif f == 2:
            fc *= 1.0 + 0.12 * s * g
            fv *= 1.0 + 0.12 * s * g
        else:
            fv += 2000.0 * s * max(math.exp(600.0 * (1.0 / (temp + 110.0) - 1.0 / 170.0)) - 1.0,
                                   0.0)
    if E[E_LOAD, 1] > 0.0:
        f = int(E[E_LOAD, 0])
        s = E[E_LOAD, 1]
        ta = math.sqrt(T * T + 1.0)
        if f == 0:
            fc += 0.004 * s * ta
        elif f == 1:
            fac = 1.0 + 0.15 * s * ta / RATED_LOAD
            fc *= fac
            fv *= fac
        elif f == 2:
            wdrive = 0.5 * (1.0 + math.tanh(T * v / 50.0))
            fc += s * ta * (0.0015 + 0.003 * wdrive)
        else:
            fc += 450.0 * s * (T / RATED_LOAD) ** 2
    if E[E_ASYM, 1] > 0.0:
        f = int(E[E_ASYM, 0])
        s = E[E_ASYM, 1]
        sg = math.tanh(v / 1e-5)
        if f == 0:
            fc += 150.0 * s * sg
        elif f == 1:
            fv *= (1.0 + 0.8 * s) ** sg
        elif f == 2:
            fc *= (1.0 + 0.06 * s) ** sg
            fv *= (1.0 + 0.4 * s) ** sg
        else:
            extra += 200.0 * s
    fss = fc
    if E[E_STRIB, 1] > 0.0:
        f = int(E[E_STRIB, 0])
        xs = abs(v) / 0.004
        if f == 0:
            sh = math.exp(-xs)
        elif f == 1:
            sh = math.exp(-xs * xs)
        elif f == 2:
            sh = 1.0 / (1.0 + xs * xs)
        else:
            sh = 1.0 / math.cosh(min(xs, 700.0))
        fss += 400.0 * E[E_STRIB, 1] * sh
    sig0 = P[P_SIG0]
    z = y[S_Z]
    zss = fss / sig0
    zba = 0.7 * zss
    az = abs(z)
    alpha = 0.0
    if v * z > 0.0:
        if az >= zss:
            alpha = 1.0
        elif az > zba:
            alpha = 0.5 * math.sin(math.pi * (az - 0.5 * (zss + zba)) / (zss - zba)) + 0.5
    dz = v * (1.0 - alpha * az / zss)
    ff = sig0 * z + P[P_SIG1] * dz + fv * v + extra
    # ---- periodic disturbance ------------------------------------------------------------
    tdist = 0.0
    if E[E_PER, 1] > 0.0:
        f = int(E[E_PER, 0])
        A = 300.0 * E[E_PER, 1]
        if f == 0:
            tdist = A * math.sin(2.0 * math.pi * 1.3 * t)
        elif f == 1:
            tdist = A * (0.7 * math.sin(2.0 * math.pi * 1.3 * t)
                         + 0.5 * math.sin(2.0 * math.pi * 3.1 * t + 0.4))
        else:
            tdist = A * (0.6 + 0.4 * math.sin(2.0 * math.pi * 0.05 * t)) \
                * math.sin(2.0 * math.pi * 2.2 * t)
    # ---- gear ripple: mesh torque ripple acting on the output body -------------------------
    if E[E_RIPPLE, 1] > 0.0:
        f = int(E[E_RIPPLE, 0])
        A = 300.0 * E[E_RIPPLE, 1]
        if f == 0:
            tdist -= A * math.sin(36.0 * q)
        elif f == 1:
            tdist -= A * (0.7 * math.sin(36.0 * q) + 0.4 * math.sin(72.0 * q + 0.5)
                          + 0.25 * math.sin(108.0 * q + 1.1))
        elif f == 2:
            tdist -= 0.4 * A * math.sin(2.0 * theta_m)
        elif f == 3:
            tdist -= A * (0.8 * math.sin(phi) + 0.4 * math.sin(2.0 * phi + 0.7))
        else:
            tdist -= A * (0.3 + 0.7 * abs(T) / RATED_LOAD) * math.sin(36.0 * q)
    grav = G * (P[P_MRX] * math.sin(q) + P[P_MRY] * math.cos(q))
    # ---- derivatives ---------------------------------------------------------------------
    for k in range(3):
        dy[S_E1 + k] = y[S_W1 + k] / n1 - wb
        w = y[S_W1 + k]
        dy[S_W1 + k] = (P[P_KT] * u[k] - mk[k] / n1 - P[P_BM] * w
                        - P[P_FCM] * math.tanh(w / 0.5)) / P[P_JM]
    dy[S_D2] = d2dot
    dy[S_Q] = v
    dy[S_WB] = (msum + (tau2_bull - T) / n2 - P[P_BB] * wb) / P[P_JB]
    dy[S_QD] = (T - tl - grav - ff + tau2 + tdist) / P[P_I]
    dy[S_Z] = dz
    # hydraulics
    psid = y[S_PSID]
    psi = q - y[S_S]
    pa = y[S_PA]
    pb = y[S_PB]
    dv = P[P_DV]
    dy[S_S] = v - psid
    dy[S_PSID] = (tl - dv * (pa - pb) - P[P_BA] * psid) / P[P_JA]
    xv = y[S_XV]
    xp = max(xv, 0.0)
    xm = max(-xv, 0.0)
    ps = P[P_PS]
    pt = P[P_PT]
    kv = P[P_KV]
    qa = kv * (xp * _ssqrt(ps - pa) - xm * _ssqrt(pa - pt))
    qb = kv * (xm * _ssqrt(ps - pb) - xp * _ssqrt(pb - pt))
    leak = P[P_CL] * (pa - pb)
    va = P[P_V0] - dv * psi
    vb = P[P_V0] + dv * psi
    dy[S_PA] = P[P_BETA] / va * (qa + dv * psid - leak)
    dy[S_PB] = P[P_BETA] / vb * (qb - dv * psid + leak)
    wv = P[P_WV]
    dy[S_XV] = y[S_XVD]
    dy[S_XVD] = wv * wv * (u[3] - xv) - 2.0 * P[P_ZV] * wv * y[S_XVD]
    # thermal
    pfric = abs(ff * v)
    pmesh = 0.03 * abs(T * v)
    pch = P[P_CCH] * ratio * wb * wb
    dy[S_TOIL] = (pfric + pmesh + pch - P[P_HA] * (temp - P[P_TAMB])) / P[P_CTH]
    for k in range(3):
        dy[S_TW1 + k] = (P[P_RW] * u[k] * u[k] - (y[S_TW1 + k] - temp) / P[P_RTH]) / P[P_CW]
    dy[S_HX] = dhx
    dy[S_Q2] = y[S_Q2D]
    dy[S_Q2D] = dq2d
    aux[A_T] = T
    aux[A_TL] = tl
    aux[A_FF] = ff
    aux[A_TWIST] = theta_m / (n1 * n2) - q
    aux[A_THETA1] = n1 * (y[S_E1] + phi)
    aux[A_G] = grav


@njit(cache=True)
def _ssqrt(d: float) -> float:
    """Signed square root regularised near zero (laminar flow below ~0.1 bar)."""
    return d / (d * d + 1e8) ** 0.25


@njit(cache=True)
def _lu(a, piv):
    n = a.shape[0]
    for k in range(n):
        p = k
        m = abs(a[k, k])
        for i in range(k + 1, n):
            if abs(a[i, k]) > m:
                m = abs(a[i, k])
                p = i
        piv[k] = p
        if p != k:
            for j in range(n):
                tmp = a[k, j]
                a[k, j] = a[p, j]
                a[p, j] = tmp
        d = a[k, k]
        if d == 0.0:
            d = 1e-300
            a[k, k] = d
        for i in range(k + 1, n):
            a[i, k] /= d
            f = a[i, k]
            if f != 0.0:
                for j in range(k + 1, n):
                    a[i, j] -= f * a[k, j]


@njit(cache=True)
def _lusolve(a, piv, b):
    n = a.shape[0]
    for k in range(n):
        p = piv[k]
        if p != k:
            tmp = b[k]
            b[k] = b[p]
            b[p] = tmp
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


@njit(cache=True)
def _profile(t, tk, vk):
    """Piecewise-linear profile through knots (tk, vk), held beyond the ends."""
    n = tk.shape[0]
    if t <= tk[0]:
        return vk[0]
    if t >= tk[n - 1]:
        return vk[n - 1]
    i = np.searchsorted(tk, t) - 1
    w = (t - tk[i]) / (tk[i + 1] - tk[i])
    return vk[i] + w * (vk[i + 1] - vk[i])


@njit(cache=True)
def _fourier(t, fa, fb, wf, sgn):
    q = 0.0
    qd = 0.0
    for l in range(fa.shape[0]):
        lw = wf * (l + 1)
        q += fa[l] / lw * math.sin(lw * t) - fb[l] / lw * math.cos(lw * t) + fb[l] / lw
        qd += fa[l] * math.cos(lw * t) + fb[l] * math.sin(lw * t)
    return sgn * q, sgn * qd


@njit(cache=True)
def _newton_matrix(y, f, t, P, E, u, aux, typ, dh, yp, fp, jac, mat, piv):
    """The TR-BDF2 stages' Newton matrix I − dh·J at (t, y), J by forward differences about
    f = rhs(t, y), LU-factorised in place (mat, piv); yp, fp and jac are scratch arrays."""
    n = y.size
    for j in range(n):
        dj = 1.5e-8 * max(abs(y[j]), typ[j])
        for i in range(n):
            yp[i] = y[i]
        yp[j] += dj
        _rhs(yp, t, P, E, u, fp, aux)
        for i in range(n):
            jac[i, j] = (fp[i] - f[i]) / dj
    for i in range(n):
        for j in range(n):
            mat[i, j] = -dh * jac[i, j]
        mat[i, i] += 1.0
    _lu(mat, piv)


@njit(cache=True)
def _simulate(y0, P, E, atol, typ, h, m, nsamp, scheme, wset, tk, vk, fa, fb, wf, sgn, counts):
    """Integrate with TR-BDF2 + simplified Newton; record every m inner steps."""
    gam = 2.0 - math.sqrt(2.0)
    d = gam / 2.0
    c1 = 1.0 / (gam * (2.0 - gam))
    c0 = (1.0 - gam) ** 2 / (gam * (2.0 - gam))
    n = NS
    y = y0.copy()
    rec = np.zeros((nsamp, NREC))
    u = np.zeros(4)
    aux = np.zeros(NAUX)
    fn = np.zeros(n)
    fy = np.zeros(n)
    fp = np.zeros(n)
    jac = np.zeros((n, n))
    mat = np.zeros((n, n))
    piv = np.zeros(n, dtype=np.int64)
    yg = np.zeros(n)
    Y = np.zeros(n)
    r = np.zeros(n)
    yp = np.zeros(n)
    enc = 2.0 * math.pi / counts
    nn = P[P_N1] * P[P_N2]
    _rhs(y, 0.0, P, E, u, fn, aux)
    th_prev = math.floor(aux[A_THETA1] / enc) * enc
    integ = 0.0
    hinteg = 0.0
    icmd = 0.0
    iv = 0.0
    hk = max(1, int(round(1e-3 / h)))
    since_jac = 1 << 30
    nsteps = nsamp * m
    wref = 0.0
    tcmd = 0.0
    fails = 0
    for step in range(nsteps + 1):
        t = step * h
        _rhs(y, t, P, E, u, fn, aux)
        # ---- controllers at t (zero-order hold over the step) ------------------------------
        th_meas = math.floor(aux[A_THETA1] / enc) * enc
        wmeas = (th_meas - th_prev) / h if step > 0 else 0.0
        th_prev = th_meas
        if scheme == 3:
            qr, qdr = _fourier(t, fa, fb, wf, sgn)
            wref = nn * (qdr + P[P_KPOS] * (qr - th_meas / nn))
        else:
            wref = wset * min(t / 1.0, 1.0)
        err = wref - wmeas
        imax = P[P_IMAX]
        integ_new = integ + P[P_KI] * err * h
        icmd = P[P_KP] * err + integ_new
        if icmd > imax:
            icmd = imax
        elif icmd < -imax:
            icmd = -imax
        else:
            integ = integ_new
        u[0] = icmd
        u[1] = max(-imax, min(imax, icmd * P[P_MIS2]))
        u[2] = max(-imax, min(imax, icmd * P[P_MIS3]))
        tcmd = _profile(t, tk, vk)
        if step % hk == 0:
            herr = tcmd - aux[A_TL]
            hth = hk * h
            dpv = max(y[S_PA] - P[P_PT], 1e5) if y[S_PSID] > 0.0 else max(P[P_PS] - y[S_PA], 1e5)
            ff_v = -P[P_DV] * y[S_PSID] / (P[P_KV] * math.sqrt(dpv))
            hnew = hinteg + P[P_HKI] * herr * hth
            iv = P[P_HKP] * herr + hnew + ff_v
            if iv > 1.0:
                iv = 1.0
            elif iv < -1.0:
                iv = -1.0
            else:
                hinteg = hnew
            u[3] = iv
        _rhs(y, t, P, E, u, fn, aux)
        if step % m == 0:
            k = step // m
            if k < nsamp:
                for i in range(n):
                    rec[k, i] = y[i]
                rec[k, R_T] = aux[A_T]
                rec[k, R_TL] = aux[A_TL]
                rec[k, R_FF] = aux[A_FF]
                rec[k, R_TWIST] = aux[A_TWIST]
                rec[k, R_TH1] = aux[A_THETA1]
                rec[k, R_I1] = u[0]
                rec[k, R_I2] = u[1]
                rec[k, R_I3] = u[2]
                rec[k, R_IV] = u[3]
                rec[k, R_TCMD] = tcmd
                rec[k, R_WREF] = wref
            else:
                break
        # ---- Jacobian (forward differences), refreshed every 40 steps --------------------
        if since_jac >= 40:
            _newton_matrix(y, fn, t, P, E, u, aux, typ, d * h, yp, fp, jac, mat, piv)
            since_jac = 0
        since_jac += 1
        # ---- stage 1: trapezoid to t + γh ---------------------------------------------------
        for i in range(n):
            Y[i] = y[i] + gam * h * fn[i]
        for stage in range(2):
            tt = t + gam * h if stage == 0 else t + h
            conv = False
            for it in range(24):
                _rhs(Y, tt, P, E, u, fy, aux)
                if stage == 0:
                    for i in range(n):
                        r[i] = -(Y[i] - y[i] - d * h * (fn[i] + fy[i]))
                else:
                    for i in range(n):
                        r[i] = -(Y[i] - c1 * yg[i] + c0 * y[i] - d * h * fy[i])
                _lusolve(mat, piv, r)
                err = 0.0
                for i in range(n):
                    Y[i] += r[i]
                    e = abs(r[i]) / atol[i]
                    if e > err:
                        err = e
                if err <= 1.0:
                    conv = True
                    break
                if it == 7 or it == 15:
                    # stalled: refresh the Jacobian at the current iterate
                    _rhs(Y, tt, P, E, u, fy, aux)
                    _newton_matrix(Y, fy, tt, P, E, u, aux, typ, d * h, yp, fp, jac, mat, piv)
                    since_jac = 1
            if not conv:
                fails += 1
            if stage == 0:
                for i in range(n):
                    yg[i] = Y[i]
                # predictor for the BDF2 stage: extrapolate with f(y_g)
                for i in range(n):
                    Y[i] = yg[i] + (1.0 - gam) * h * (yg[i] - y[i] - d * h * fn[i]) / (d * h)
        for i in range(n):
            y[i] = Y[i]
    return rec, fails


# ------------------------------------------------------------------ Python side ---------------

@dataclass
class SensorSpec:
    """What the bench's sensors resolve and how noisy they are (all stated in meta["sensors"])."""

    sample_rate_hz: float = 100.0
    encoder_res_deg: float = 0.01
    torque_noise: float = 150.0
    torque_lag_s: float = 0.0
    torque_adc_step: float = 6.1
    load_noise: float = 100.0
    motor_counts_per_rev: float = 1048576.0
    current_noise: float = 0.02
    temp_noise: float = 0.05
    pressure_noise: float = 2e4

    _RANGES = {
        "sample_rate_hz": (10.0, 1000.0), "encoder_res_deg": (1e-6, 1.0),
        "torque_noise": (0.0, 1e4), "torque_lag_s": (0.0, 1.0), "torque_adc_step": (0.0, 1e3),
        "load_noise": (0.0, 1e4), "motor_counts_per_rev": (16.0, 2.0 ** 32),
        "current_noise": (0.0, 10.0), "temp_noise": (0.0, 5.0), "pressure_noise": (0.0, 1e7),
    }

    def __post_init__(self) -> None:
        for f in fields(self):
            v = getattr(self, f.name)
            if isinstance(v, bool) or not isinstance(v, (int, float, np.integer, np.floating)):
                raise ValueError(f"{f.name} must be a number, got {v!r}")
            v = float(v)
            if not math.isfinite(v):
                raise ValueError(f"{f.name} must be finite, got {v!r}")
            lo, hi = self._RANGES[f.name]
            if not lo <= v <= hi:
                raise ValueError(f"{f.name} must lie in [{lo}, {hi}], got {v!r}")
            setattr(self, f.name, v)


# dataclass treats the class attribute _RANGES (no annotation) as a plain attribute.


@dataclass
class RigRun:
    """One simulated run: samples and meta in the run format, the truth and the parameters."""

    samples: pd.DataFrame
    meta: dict[str, Any]
    truth: pd.DataFrame
    params: dict[str, Any]


def campaign_machine(seed: int) -> dict[str, Any]:
    """The campaign's machine drawn from `seed` (the same seed gives the same machine)."""
    _check_int("seed", seed)
    rng = np.random.default_rng([int(seed), 0x56])

    def spread(v: float, rel: float) -> float:
        return float(v * (1.0 + rel * np.clip(rng.standard_normal(), -2.5, 2.5)))

    mach = {
        "I": spread(TABLE3["I"], 0.005), "mr_x": spread(TABLE3["mr_x"], 0.03),
        "mr_y": spread(TABLE3["mr_y"], 0.03), "f_v": spread(TABLE3["f_v"], 0.002),
        "f_c": spread(TABLE3["f_c"], 0.003),
        "k_lin": spread(1.3e7, 0.03), "T_s": spread(5e3, 0.05), "theta_s": 2e-4,
        "c_2": 6e4, "beta": spread(1.4e9, 0.05),
        "mismatch_2": float(1.0 + rng.uniform(-0.015, 0.015)),
        "mismatch_3": float(1.0 + rng.uniform(-0.015, 0.015)),
    }
    unstated = {
        "torque_crosstalk_per_bend": float(rng.uniform(0.002, 0.004)),
        "torque_zero_offset_nm": float(40.0 * np.clip(rng.standard_normal(), -2.5, 2.5)),
        "torque_extra_lag_s": 0.002,
        "encoder_interp_amp_frac": float(rng.uniform(0.1, 0.25)),
        "encoder_interp_periods_per_rev": 9000.0,
        "load_cell_gain": float(1.0 + 0.002 * np.clip(rng.standard_normal(), -2.5, 2.5)),
        "oil_viscosity_friction": {"phi_oil": 0.2, "T_ref_c": T_REF_C, "B_K": 1000.0,
                                   "C_K": 120.0},
    }
    return {"machine": mach, "unstated": unstated}


def _param_vector(mach: dict[str, float], temp0: float) -> np.ndarray:
    P = np.zeros(P_NPAR)
    P[P_I], P[P_MRX], P[P_MRY], P[P_FV], P[P_FC] = (mach["I"], mach["mr_x"], mach["mr_y"],
                                                    mach["f_v"], mach["f_c"])
    n1 = 11.0
    P[P_N1], P[P_N2] = n1, REDUCTION / n1
    P[P_JM], P[P_JB] = 5e-4, 1.0
    P[P_K1], P[P_C1] = 200.0 * n1 * n1, 0.05 * n1 * n1
    P[P_BM], P[P_FCM], P[P_BB] = 1e-4, 0.05, 0.02
    P[P_KLIN], P[P_TS], P[P_THS], P[P_C2] = mach["k_lin"], mach["T_s"], mach["theta_s"], mach["c_2"]
    P[P_SIG0] = mach["f_c"] / 3e-5
    P[P_SIG1] = 1.5e5
    P[P_KLS], P[P_CLS], P[P_JA], P[P_BA] = 2e7, 2e4, 80.0, 2e3
    P[P_DV], P[P_BETA], P[P_V0], P[P_CL] = 1e-2, mach["beta"], 0.028, 2e-12
    P[P_KV], P[P_PS], P[P_PT] = 3.8e-7, 21e6, 0.3e6
    P[P_WV], P[P_ZV] = 2.0 * math.pi * 50.0, 0.7
    P[P_CTH], P[P_HA], P[P_TAMB], P[P_PHIOIL], P[P_CCH] = 2e5, 60.0, min(temp0, 22.0), 0.2, 0.05
    P[P_RW], P[P_CW], P[P_RTH] = 0.8, 800.0, 0.6
    P[P_KT], P[P_MIS2], P[P_MIS3], P[P_IMAX] = 1.0, mach["mismatch_2"], mach["mismatch_3"], 12.0
    P[P_KP], P[P_KI], P[P_KPOS] = 0.12, 2.4, 1.5
    P[P_HKP], P[P_HKI] = 3e-5, 1.5e-4
    return P


_ATOL = np.array([1e-10] * 3 + [1e-12, 1e-11] + [1e-6] * 3 + [1e-7, 1e-10, 1e-13, 1e-12, 1e-10,
                 10.0, 10.0, 1e-8, 1e-6, 1e-7, 1e-6, 1e-6, 1e-6, 1e-8, 1e-10, 1e-9])


_TYP = np.array([1e-4] * 3 + [1e-2, 1.0] + [300.0] * 3 + [30.0, 0.03, 3e-5, 1e-2, 0.03, 1e7, 1e7,
                 1.0, 300.0, 30.0, 30.0, 30.0, 30.0, 1.0, 1e-3, 0.03])
"""Typical magnitude of each state: the floor of the finite-difference perturbation."""


def _fourier_coeffs() -> tuple[np.ndarray, np.ndarray, float]:
    """Eq. 12 coefficients scaled so the peak output speed is 90 % of the 3000 r/min limit."""
    wf = 2.0 * math.pi / FOURIER_PERIOD
    tt = np.linspace(0.0, FOURIER_PERIOD, 4001)
    qd = sum(_FA[l] * np.cos(wf * (l + 1) * tt) + _FB[l] * np.sin(wf * (l + 1) * tt)
             for l in range(5))
    k = 0.9 * OUT_SPEED_MAX / np.max(np.abs(qd))
    return _FA * k, _FB * k, wf


def _schedule(scheme: int, periods: int) -> tuple[float, np.ndarray, np.ndarray]:
    """Run duration and dynamometer set-point knots of a scheme."""
    if scheme == 1:
        tk = [0.0, 4.0, 34.0, 36.0, 66.0, 70.0]
        vk = [0.0, 0.0, RATED_LOAD, RATED_LOAD, 0.0, 0.0]
        return 70.0, np.array(tk), np.array(vk)
    if scheme == 2:
        tk, vk = [0.0, 4.0], [0.0, 0.0]
        for s in range(12):
            t0 = 4.0 + 3.0 * s
            tk += [t0 + 1.0, t0 + 3.0]
            vk += [10e3 * (s + 1)] * 2
        tk += [52.0, 55.0]
        vk += [0.0, 0.0]
        return 55.0, np.array(tk), np.array(vk)
    return FOURIER_PERIOD * periods, np.array([0.0, 1.0]), np.array([0.0, 0.0])


def _phases(scheme: int, t: np.ndarray) -> np.ndarray:
    ph = np.full(t.shape, "idle", dtype=object)
    if scheme == 1:
        ph[(t >= 4.0) & (t < 34.0)] = "load"
        ph[(t >= 34.0) & (t < 36.0)] = "hold"
        ph[(t >= 36.0) & (t < 66.0)] = "unload"
    elif scheme == 2:
        inside = (t >= 4.0) & (t < 40.0)
        frac = np.mod(t - 4.0, 3.0)
        ph[inside & (frac < 1.0)] = "load"
        ph[inside & (frac >= 1.0)] = "hold"
        ph[(t >= 40.0) & (t < 52.0)] = "unload"
    else:
        ph[:] = "excite"
    return ph


def _check_int(name: str, v: Any) -> None:
    if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < 0:
        raise ValueError(f"{name} must be a non-negative integer, got {v!r}")


def _check_effects(effects: Any) -> dict[str, tuple[int, float]]:
    """Validated {name: (form index, scale)} with every zero scale dropped."""
    if effects is None:
        return {}
    if not isinstance(effects, dict):
        raise ValueError(f"effects must be a dict {{name: {{form, scale}}}}, got {effects!r}")
    out: dict[str, tuple[int, float]] = {}
    for name, spec in effects.items():
        if name not in EFFECT_FORMS:
            raise ValueError(f"effects: unknown effect {name!r}; known: {list(EFFECT_FORMS)}")
        if not isinstance(spec, dict) or set(spec) - {"form", "scale"} or "form" not in spec \
                or "scale" not in spec:
            raise ValueError(f"effects[{name!r}] must be {{'form': ..., 'scale': ...}}, got {spec!r}")
        form = spec["form"]
        if form not in EFFECT_FORMS[name]:
            raise ValueError(f"effects[{name!r}]: unknown form {form!r}; known: "
                             f"{list(EFFECT_FORMS[name])}")
        s = spec["scale"]
        if isinstance(s, bool) or not isinstance(s, (int, float, np.integer, np.floating)) \
                or not math.isfinite(float(s)):
            raise ValueError(f"effects[{name!r}] scale must be a finite number, got {s!r}")
        s = float(s)
        if s < 0.0:
            raise ValueError(f"effects[{name!r}] scale must be >= 0, got {s!r}")
        if s > SCALE_MAX:
            raise ValueError(f"effects[{name!r}] scale {s!r} exceeds SCALE_MAX = {SCALE_MAX}")
        if s > 0.0:
            out[name] = (EFFECT_FORMS[name].index(form), s)
    return out


def _delay(t: np.ndarray, x: np.ndarray, lag: float) -> np.ndarray:
    """x seen `lag` seconds late (linear interpolation on the sample grid, first value held)."""
    if lag <= 0.0:
        return x
    return np.interp(t - lag, t, x, left=x[0])


def simulate_run(scheme: int, motor_speed_rpm: float | None, direction: int, temp_joint_c: float,
                 effects: dict[str, dict] | None = None, *, sensors: SensorSpec | None = None,
                 periods: int = 3, seed: int, run: int) -> RigRun:
    """Simulate one run of the bench: scheme 1/2 (constant motor speed, dynamometer loading to
    120 kN·m) or 3 (Eq. 12 Fourier excitation, `periods` periods). `seed` fixes the campaign's
    machine, (seed, run) the run's noise; effects {name: {"form", "scale"}} are injected."""
    if isinstance(scheme, bool) or scheme not in (1, 2, 3):
        raise ValueError(f"scheme must be 1, 2 or 3, got {scheme!r}")
    if scheme in (1, 2):
        if isinstance(motor_speed_rpm, bool) or not isinstance(
                motor_speed_rpm, (int, float, np.integer, np.floating)) \
                or not math.isfinite(float(motor_speed_rpm)) \
                or not 0.0 < float(motor_speed_rpm) <= 3000.0:
            raise ValueError(f"motor_speed_rpm must be a number in (0, 3000] for scheme "
                             f"{scheme}, got {motor_speed_rpm!r}")
        rpm = float(motor_speed_rpm)
    else:
        if motor_speed_rpm is not None:
            raise ValueError(f"motor_speed_rpm must be None for scheme 3, got {motor_speed_rpm!r}")
        rpm = None
    if isinstance(direction, bool) or direction not in (1, -1):
        raise ValueError(f"direction must be +1 or -1, got {direction!r}")
    if isinstance(temp_joint_c, bool) or not isinstance(
            temp_joint_c, (int, float, np.integer, np.floating)) \
            or not math.isfinite(float(temp_joint_c)) or not 15.0 <= float(temp_joint_c) <= 60.0:
        raise ValueError(f"temp_joint_c must be a number in [15, 60] °C, got {temp_joint_c!r}")
    temp0 = float(temp_joint_c)
    if isinstance(periods, bool) or not isinstance(periods, (int, np.integer)) \
            or not 1 <= periods <= 50:
        raise ValueError(f"periods must be an integer in [1, 50], got {periods!r}")
    _check_int("seed", seed)
    _check_int("run", run)
    if sensors is None:
        sensors = SensorSpec()
    elif not isinstance(sensors, SensorSpec):
        raise ValueError(f"sensors must be a SensorSpec, got {sensors!r}")
    eff = _check_effects(effects)

    camp = campaign_machine(seed)
    mach, unst = camp["machine"], camp["unstated"]
    P = _param_vector(mach, temp0)
    E = np.zeros((13, 2))
    for name, (fi, s) in eff.items():
        if name not in _SENSOR_ONLY:
            E[_EFFECT_INDEX[name]] = (fi, s)

    sr = sensors.sample_rate_hz
    ts = 1.0 / sr
    m = int(math.ceil(ts / 5e-4 - 1e-9))
    h = ts / m
    dur, tk, vk = _schedule(scheme, int(periods))
    nsamp = int(round(dur * sr))
    fa, fb, wf = _fourier_coeffs()
    wset = direction * (rpm if rpm is not None else 0.0) * 2.0 * math.pi / 60.0

    y0 = np.zeros(NS)
    y0[S_PA] = y0[S_PB] = 0.5 * (P[P_PS] + P[P_PT])
    y0[S_TOIL] = temp0
    y0[S_TW1:S_TW3 + 1] = temp0
    grav0 = G * P[P_MRY]
    y0[S_Z] = -grav0 / P[P_SIG0]  # presliding bristles hold gravity at rest

    rec, fails = _simulate(y0, P, E, _ATOL, _TYP, h, m, nsamp, scheme, wset, tk, vk, fa, fb, wf,
                           float(direction), sensors.motor_counts_per_rev)
    t = np.arange(nsamp) * ts
    return _assemble(t, rec, scheme, rpm, direction, temp0, sensors, eff, mach, unst, seed, run,
                     int(periods), h, int(fails))


def _assemble(t, rec, scheme, rpm, direction, temp0, sensors, eff, mach, unst, seed, run,
              periods, h, fails) -> RigRun:
    rng = np.random.default_rng([int(seed), int(run), 0x76])
    n = len(t)
    nn = REDUCTION
    q_true = rec[:, S_Q]
    T_true = rec[:, R_T]
    tl_true = rec[:, R_TL]
    temp_oil = rec[:, S_TOIL]
    th1 = rec[:, R_TH1]
    m_bend = 50e3 * (1.0 - np.exp(-t / 0.8))
    f_shear = 30e3 * (1.0 - np.exp(-t / 0.8))

    def quant(x: np.ndarray, step: float) -> np.ndarray:
        return np.round(x / step) * step if step > 0 else x

    # output encoder: interpolation error (unstated), optional drift/lag effects, quantisation
    res_q = math.radians(sensors.encoder_res_deg)
    qr = q_true + unst["encoder_interp_amp_frac"] * res_q * np.sin(
        unst["encoder_interp_periods_per_rev"] * q_true)
    if "time_delay" in eff and eff["time_delay"][0] == 2:
        qr = _delay(t, qr, 0.05 * eff["time_delay"][1])
    if "sensor_drift" in eff and eff["sensor_drift"][0] == 1:
        qr = qr + 2e-4 * eff["sensor_drift"][1] * t / 60.0
    q_meas = quant(qr, res_q)
    enc = 2.0 * math.pi / sensors.motor_counts_per_rev
    u_meas = np.floor(th1 / enc) * enc / nn
    res_u = enc / nn

    # torque transducer
    lag = sensors.torque_lag_s + unst["torque_extra_lag_s"]
    tr = _delay(t, T_true, lag)
    if "time_delay" in eff:
        fi, s = eff["time_delay"]
        if fi == 0:
            tr = _delay(t, tr, 0.05 * s)
        elif fi == 1:
            a = math.exp(-(t[1] - t[0]) / (0.05 * s))
            out = np.empty_like(tr)
            acc = tr[0]
            for i in range(n):
                acc = a * acc + (1.0 - a) * tr[i]
                out[i] = acc
            tr = out
    tr = tr + unst["torque_crosstalk_per_bend"] * m_bend + unst["torque_zero_offset_nm"]
    if "torque_offset" in eff:
        fi, s = eff["torque_offset"]
        tr = tr + {0: lambda: 300.0 * s + 0 * t,
                   1: lambda: 300.0 * s * t / 60.0,
                   2: lambda: 400.0 * s * (1.0 - np.exp(-t / 15.0)),
                   3: lambda: 300.0 * s * (1.0 + 0.03 * (temp_oil - 25.0))}[fi]()
    if "sensor_drift" in eff and eff["sensor_drift"][0] == 0:
        tr = tr * (1.0 + 0.004 * eff["sensor_drift"][1] * t / 60.0)
    torque_meas = quant(tr + sensors.torque_noise * rng.standard_normal(n),
                        sensors.torque_adc_step)
    tlr = tl_true * unst["load_cell_gain"]
    if "sensor_drift" in eff and eff["sensor_drift"][0] == 2:
        tlr = tlr + 300.0 * eff["sensor_drift"][1] * t / 60.0
    tl_meas = quant(tlr + sensors.load_noise * rng.standard_normal(n), sensors.torque_adc_step)

    cols: dict[str, Any] = {"t": t, "q": q_meas, "u": u_meas, "torsion": q_meas - u_meas,
                            "torque": torque_meas, "torque_load": tl_meas,
                            "torque_cmd": rec[:, R_TCMD]}
    cols["ud"] = rec[:, S_W1] / nn + 0.01 / nn * rng.standard_normal(n)
    for k in range(3):
        cols[f"i_m{k + 1}"] = quant(rec[:, R_I1 + k] + sensors.current_noise
                                    * rng.standard_normal(n), 1e-3)
    for k in range(3):
        cols[f"w_m{k + 1}"] = rec[:, S_W1 + k] + 0.01 * rng.standard_normal(n)
    for k in range(3):
        cols[f"temp_m{k + 1}"] = quant(rec[:, S_TW1 + k] + sensors.temp_noise
                                       * rng.standard_normal(n), 0.1)
    cols["temp_joint"] = quant(temp_oil + sensors.temp_noise * rng.standard_normal(n), 0.1)
    cols["p_hyd"] = quant(rec[:, S_PA] + sensors.pressure_noise * rng.standard_normal(n), 1e3)
    cols["m_bend"] = quant(m_bend + 200.0 * rng.standard_normal(n), 10.0)
    cols["f_shear"] = quant(f_shear + 100.0 * rng.standard_normal(n), 10.0)
    cols["phase"] = _phases(scheme, t)
    samples = pd.DataFrame(cols)

    meta = {
        "scheme": int(scheme), "motor_speed_rpm": rpm, "direction": int(direction),
        "reduction": REDUCTION, "rig": RIG_NAME, "source": "emulator",
        "sample_rate_hz": float(sensors.sample_rate_hz),
        "started_at": "2026-01-01T00:00:00Z",
        "notes": f"validation rig V, campaign seed {seed}, run {run}",
        "bend_setpoint_nm": 50e3, "shear_setpoint_n": 30e3,
        "sensors": {
            "q": {"resolution": res_q, "noise_sd": 0.0, "lag_s": 0.0},
            "u": {"resolution": res_u, "noise_sd": 0.0, "lag_s": 0.0},
            "torque": {"resolution": sensors.torque_adc_step, "noise_sd": sensors.torque_noise,
                       "lag_s": sensors.torque_lag_s},
            "torque_load": {"resolution": sensors.torque_adc_step,
                            "noise_sd": sensors.load_noise, "lag_s": 0.0},
            **{f"i_m{k}": {"resolution": 1e-3, "noise_sd": sensors.current_noise, "lag_s": 0.0}
               for k in (1, 2, 3)},
            "temp_joint": {"resolution": 0.1, "noise_sd": sensors.temp_noise, "lag_s": 0.0},
            "p_hyd": {"resolution": 1e3, "noise_sd": sensors.pressure_noise, "lag_s": 0.0},
        },
    }
    truth = pd.DataFrame({
        "t": t, "q": q_true, "qd": rec[:, S_QD], "u": th1 / nn, "twist": rec[:, R_TWIST],
        "torque": T_true, "torque_load": tl_true, "friction": rec[:, R_FF],
        "temp_oil": temp_oil, "z": rec[:, S_Z], "hyst_x": rec[:, S_HX],
        "speed_ref_motor": rec[:, R_WREF], "valve_cmd": rec[:, R_IV],
    })
    params = {
        "machine": dict(mach), "unstated": dict(unst),
        "effects": {name: {"form": EFFECT_FORMS[name][fi], "scale": s}
                    for name, (fi, s) in eff.items()},
        "inner_step_s": h, "newton_failures": fails, "temp_ref_c": T_REF_C,
        "sensors": asdict(sensors), "seed": int(seed), "run": int(run), "periods": periods,
    }
    return RigRun(samples=samples, meta=meta, truth=truth, params=params)
