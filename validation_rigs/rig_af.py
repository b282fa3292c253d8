"""Rig AF: an independent validation simulator of the J4 joint test bench.

Written from the paper (Eq. 4 output balance, Eq. 5 elastic transmission, Table 3) and the shared
docs only; it shares no code or model form with simulators/ or the other validation rigs. The
data sheet below is what tests/test_rig_af.py re-derives its checks from.

DATA SHEET (SI units; temperatures in °C; "output-referred" = seen at the joint output)
========================================================================================

0. Symbols
   q, q̇ output angle / speed [rad, rad/s]; u motor angle / N (N = 11000) [rad]; Δ = u − q the
   twist [rad]; T the transmitted torque [N·m]; τ_L the dynamometer torque on the output
   (positive = the paper's positive loading); θ_g the gearbox temperature [°C];
   g = 9.81 m/s²; T_r = 120 000 N·m (rated); ω_top = 3000·2π/60/N = 0.028560 rad/s.

1. Machine (draw_machine(seed): value·(1 + sd·ε), ε ~ N(0,1) clipped to ±2.5; `seed` is the
   campaign; shares renormalised to sum 1)
   | name          | nominal     | rel. SD | meaning                                          |
   | I             | 6685.166    | 0.02    | output inertia [kg·m²] (Table 3 I_xx)            |
   | mr_x, mr_y    | 20.779, −34.543 | 0.06 | gravity moments [kg·m] (Table 3)               |
   | f_c           | 2352.660    | 0.02    | output Coulomb friction [N·m] (Table 3)          |
   | f_v           | 8683.272    | 0.03    | output viscous friction [N·m·s/rad] (Table 3)    |
   | twist_rated   | 0.50° (rad) | 0.04    | twist at which K(Δ) = T_r                        |
   | stiff_ratio ρ | 1.45        | 0.04    | K'(twist_rated) / K'(0)                          |
   | zeta_t        | 0.30        | 0.10    | damping ratio of the output mode at zero twist   |
   | bs_rho        | 0.12        | 0.10    | Bliman–Sorine overshoot ratio                    |
   | bs_eps        | 1.2e-4      | 0.10    | Bliman–Sorine slow path length [rad]             |
   | bs_eta        | 0.15        | 0       | fast/slow path-length ratio                      |
   | J_m           | 1.8e-3      | 0.03    | rotor inertia of one motor [kg·m²]               |
   | F_mc, f_mv    | 1800, 20000 | 0.05    | motor-side Coulomb [N·m], viscous [N·m·s/rad], output-referred |
   | kt1..kt3      | 1.25        | 0.02    | torque constants [N·m/A]                         |
   | share1..3     | 1/3         | 0.02    | torque shares of the three motors                |
   | dyn_gain      | 1.0         | 0.003   | dynamometer gain                                 |
   | dyn_tau       | 0.06        | 0.10    | dynamometer first-order lag [s]                  |
   Derived: J_M = 3·J_m·N² (referred motor inertia); k0 = T_r / (Δ_r·(1 + (ρ−1)/1.5));
   k_h = (ρ−1)·k0 / (1.5·√Δ_r); c0 = 2·zeta_t·√(k0·I); gear efficiency η_g = 0.9.

2. Physics (nominal, no effects)
   Transmission, a Hertzian-contact compliance (linear + |Δ|^1.5) and a twist-growing damper:
       K(Δ) = k0·Δ + k_h·sgn(Δ)·|Δ|^1.5,      c(Δ) = c0·(1 + |Δ|/Δ_r),
       T = K(Δ) + c(Δ)·Δ̇.
   Output (paper Eq. 4 plus the load): I·q̈ = T − τ_L − g·(mr_x·sin q + mr_y·cos q) − F,
       F = x1 + x2 + f_v·q̇, with the second-order Bliman–Sorine friction (path s = ∫|q̇|dt):
       ẋ1 = (q̇·(1+ρ_bs)·L − |q̇|·x1) / (η_bs·ε),   ẋ2 = (−q̇·ρ_bs·L − |q̇|·x2) / ε,
       L = f_c (the Coulomb level; effects change it). In steady sliding x1 + x2 = L·sgn(q̇), so
       F = f_c·sgn(q̇) + f_v·q̇ exactly (Eq. 4); after a reversal the friction rises over
       η·ε ≈ 1.8e-5 rad of output motion to (1+ρ)·f_c and relaxes to f_c over ε ≈ 1.2e-4 rad.
   Motors: J_M·ü = τ_m − T − F_m,  F_m = F_mc·u̇/√(u̇² + (1e-4)²) + f_mv·u̇; motor k carries
       share_k·τ_m, current i_k = share_k·τ_m / (kt_k·N·η_g); |τ_m| ≤ 250 kN·m.
   Controller (motor side, S120-like): outer P on angle, PI on speed, load + friction
       feed-forward, ω_c = 25 rad/s:  v* = u̇_ref + (ω_c/5)·(u_ref − u),
       τ_m = J_M·ü_ref + K_v·(v* − u̇) + K_v·(ω_c/5)·∫(v* − u̇)dt + τ_cmd
             + (f_c + F_mc)·s(u̇_ref) + (f_v + f_mv)·u̇_ref,  K_v = J_M·ω_c, s(v) = v/√(v²+1e-8).
   Dynamometer: τ̇_d = (dyn_gain·τ_cmd − τ_d)/dyn_tau; τ_L = τ_d + w(t)·|τ_cmd|/T_r with a per-run
       wander w(t) = Σ_3 a_j·sin(2π·ν_j·t + φ_j), ν_j ∈ [0.03, 0.4] Hz, RMS 250 N·m (`run`).
       Scheme 3 has τ_cmd = 0, so τ_L = 0.
   Thermal: C_g·θ̇_g = |F·q̇| + |F_m·u̇| − (θ_g − θ_amb)/R_g, C_g = 1.5e5 J/K, R_g = 0.02 K/W;
       windings C_m·θ̇_k = R_w·i_k² − (θ_k − θ_amb)/R_m, C_m = 2500 J/K, R_w = 1.2 Ω,
       R_m = 0.5 K/W. All start at θ_amb = temp_joint_c.
   Initial state: q = 0, q̇ = 0, friction states 0, T = g·mr_y (the transmission holds gravity),
       u = Δ0 with K(Δ0) = g·mr_y.
   Integrator: 4th-order Adams–Bashforth–Moulton predictor–corrector (PECE), fixed step
       H_STEP = 1e-4 s, constant-derivative start-up history; discrete parts (Preisach relays,
       torque filter) updated after every step; records every REC_EVERY = 4 steps (0.4 ms).

3. Schemes (LEAD_S = 1 s idle lead-in, motor speed ramp (raised cosine) 0.1 → 0.6 s; TAIL_S = 1 s)
   1: constant motor speed direction·rpm; per period (S1_PERIOD = 24 s): load 0 → T_r linearly
      in 12 s ("load"), T_r → 0 in 12 s ("unload").
   2: constant speed; per period (S2_PERIOD = 33.8 s): 12 steps of 10 kN·m, each a 0.4 s linear
      rise ("load") then 2.0 s "hold"; then T_r → 0 in 5 s ("unload").
   3: fifth-order Fourier trajectory (Eq. 12) of the motor reference, period S3_PERIOD = 20 s,
      u_ref = u0 + direction·(qF(t − LEAD) − qF(0)), coefficients FOURIER_A/B with q̇F(0) = q̈F(0)
      = 0, scaled to max|q̇F| = 0.9·ω_top; no load ("excite").
   The dynamometer loads positively in both directions (τ_cmd ≥ 0): with direction −1 the load
   back-drives the joint. Travel must stay within ±(π − 0.1) rad (ValueError otherwise).

4. Sensors (SensorSpec; readings at instants t_k = k/fs + jitter, jitter uniform
   ±min(timing_jitter_s, 0.25/fs), t_0 = 0; the `t` column holds the true instants)
   q: output encoder, round-to-step at encoder_res_deg (0.01°).  u: motor encoder / N, step
   motor_encoder_res (2π/2^18/N).  qd, ud: true speed + white noise.  torque: the transmitted T
   through a 4th-order Bessel low-pass with DC group delay torque_filter_s (1.5 ms; exact modal
   ZOH discretisation at H_STEP), then a pure lag torque_lag_s, white noise torque_noise (110
   N·m), ADC step torque_res (500 kN·m / 2^17).  torque_load: shaft torque + noise, step.
   torque_cmd: set point, exact.  i_m·: current + noise.  w_m·: N·(u̇ + noise).  temperatures:
   + noise, step temp_res. torsion = q − u of the readings. meta["sensors"] states all of it
   (torque lag_s = torque_filter_s + torque_lag_s); meta["timing_jitter_s"] the jitter bound.

5. Effects: {name: {"form", "scale"}}, 0 ≤ scale ≤ SCALE_MAX; scale 1 = the size below; every
   contribution is proportional to scale (exactly, or to first order for laws inside a
   nonlinearity). L is the Coulomb level of section 2, v = q̇, θ = θ_g, Δ_r = twist_rated.
   stribeck (added to L, i.e. reached in steady sliding):
     stretched_exp_0p8   ΔL = s·0.2·f_c·exp(−(|v|/3.0e-3)^0.8)
     plateau_ramp        ΔL = s·0.2·f_c·clip((8.0e-3 − |v|)/(8.0e-3 − 1.5e-3), 0, 1)
     sech_decay          ΔL = s·0.2·f_c·sech(|v|/3.0e-3)
     (Fs/Fc = 1.2 at scale 1; the falling slope stays below the output's damping to the
     speed-controlled motor up to scale ≈ 2–3; larger scales give real stick–slip at 300 r/min)
   load_dependent_friction (T = transmitted torque):
     dead_band_coulomb   ΔL = s·0.02·max(|T| − 30 000, 0)
     load_scaled_viscous ΔF = s·3.0·(|T|/T_r)·f_v·v
     backdrive_coulomb   ΔL = s·0.015·|T|·b,  b = ½·(1 − P/√(P² + 20²)), P = T·v [W]
                         (b ≈ 1 when the load back-drives the joint, ≈ 0 when it is driven)
   temperature_friction (zero at θ = 25 °C):
     walther_viscous     ΔF = s·(√(ν(θ)/ν(25)) − 1)·f_v·v, ν by Walther's law
                         log10(log10(ν + 0.7)) = A − B·log10(θ + 273.15) through ISO VG 220
                         (ν(40) = 220 cSt, ν(100) = 19 cSt)
     coulomb_thermal_slope ΔL = −s·0.006·(θ − 25)·f_c
     exp_decay_both      ΔL = s·e·f_c, ΔF = s·e·f_v·v, e = exp(−0.012·(θ − 25)) − 1
   gear_ripple:
     mesh_kinematic_sidebands  transmission error on the twist, Δ → Δ − s·E(q),
                         E = 5e-5·[sin(72q) + 0.35·sin(71q + 0.4) + 0.35·sin(73q + 1.1)] rad
     motor_1x_3x         Δ → Δ − s·1.2e-5·[sin(Nu + 0.3) + 0.6·sin(3Nu + 1.2)] rad (1 and 3 per
                         motor revolution)
     load_growing_mesh   T += s·700·(0.25 + |K(Δ)|/T_r)·sin(48q + 0.5) N·m
   torque_offset (on the torque reading only):
     jump_after_unload   +s·700 N·m from the first instant the true T is 5 kN·m below its running
                         maximum (the first unloading; never in scheme 3)
     log_creep           +s·150·ln(1 + t/5 s) N·m
     slow_wander         +s·450·sin(2π·t/150 s) N·m
   time_delay (readings only): torque_bus_latency torque lags s·5 ms; q_channel_lag q and qd lag
     s·8 ms; u_channel_lag u, ud and w_m· lag s·6 ms.
   hysteresis (torque added to T, rate-independent):
     preisach_relays     h = −s·1500·mean(r_i) over 64 relays r_i = ±1 on the twist that switch
                         up at Δ ≥ c_i + w_i and down at Δ ≤ c_i − w_i, c_i ∈ 8 centres
                         linspace(−0.9, 0.9)·Δ_r, w_i ∈ 8 half-widths linspace(0.04, 0.5)·Δ_r
                         (all 64 pairs); start r_i = +1 if Δ0 ≥ c_i else −1. The relays are a
                         hysteretic slip (a twist that lags the torque), so h enters with a minus
                         sign: ∮h·dΔ > 0, the loop dissipates (it also softens the law by up to
                         s·1500 N·m at large twist).
     duhem_envelope      ḣ = (|Δ̇|/(0.12·Δ_r))·(s·1200·sgn(Δ̇)/(1 + (Δ/Δ_r)²) − h)
     bouc_wen_n1_normalised h = s·1000·z, ż = (Δ̇ − ½|Δ̇|z − ½Δ̇|z|)/(0.1·Δ_r)
   backlash (dead zone on the twist, half-gap b; the damper acts through the contact only:
     T = K(D(Δ)) + c(D(Δ))·D'(Δ)·Δ̇):
     crisp_gap           D = Δ − b·sgn(Δ) for |Δ| > b, else 0;  b = s·3e-4 rad
     hyperbolic_soft_gap D = ½(Δ−b + √((Δ−b)² + ε²)) + ½(Δ+b − √((Δ+b)² + ε²)), ε = 0.6·b
                         (D(0) = 0), b = s·3e-4 rad
     thermal_gap         crisp, b = s·3e-4·(1 + 0.025·(θ − 25)) rad
   asymmetric_friction:
     heavier_negative_coulomb  L·(1 + 0.25·s) for v < 0
     steeper_positive_viscous  f_v·(1 + 0.35·s) for v > 0
     mirror_skew               v > 0: L·(1 + 0.12s), f_v·(1 − 0.15s); v < 0: L·(1 − 0.12s),
                               f_v·(1 + 0.15s)
   periodic_disturbance (external torque d subtracted in the output balance):
     pump_pulsation      d = s·450·[sin(2π·1.7t) + 0.4·sin(2π·3.4t + 1)] N·m
     beating_fan         d = s·350·sin(2π·0.9t)·(1 + 0.6·sin(2π·0.04t)) N·m
   position_dependent_stiffness (K multiplied, floored at 0.2):
     elliptic_2x         K·(1 + 0.08·s·cos(2q + 0.3))
     sector_sigmoid      K·(1 + 0.07·s·q/√(q² + 0.25²))
   encoder_drift (readings only): q_saturating_creep q + s·2.5e-3·(1 − exp(−t/60)) rad;
     u_root_creep u + s·2.0e-3·√(t/100) rad.
   second_resonance (an extra inertia–spring on the output, ζ fixed):
     tip_mass_mode       I2 = s·0.2·I at 14 Hz, ζ = 0.02, coupled to q (no load on it)
     dyno_shaft_mode     the load passes a shaft to a dynamometer rotor I_d = s·0.1·I at 20 Hz,
                         ζ = 0.05: I_d·q̈_d = τ_s − τ_L, τ_s = k_d(q − q_d) + c_d(q̇ − q̇_d); the
                         output sees −τ_s instead of −τ_L; torque_load reads τ_s.

6. Truth (RigRun.truth at the sample instants): t, q, qd, qdd, u, ud, twist (u − q), twist_rate,
   torque (T), torque_sensor (after the Bessel filter), torque_load (on the output), torque_cmd,
   friction (F incl. effects), gravity, disturbance, motor_torque, temp_joint, temp_m1..3,
   hysteresis (the hysteretic torque in T).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numba as nb
import numpy as np
import pandas as pd

RIG_NAME = "rig_af"
REDUCTION = 11000.0
SEED_IS_CAMPAIGN = True
SCALE_MAX = 10.0

EFFECT_FORMS: dict[str, tuple[str, ...]] = {
    "stribeck": ("stretched_exp_0p8", "plateau_ramp", "sech_decay"),
    "load_dependent_friction": ("dead_band_coulomb", "load_scaled_viscous", "backdrive_coulomb"),
    "temperature_friction": ("walther_viscous", "coulomb_thermal_slope", "exp_decay_both"),
    "gear_ripple": ("mesh_kinematic_sidebands", "motor_1x_3x", "load_growing_mesh"),
    "torque_offset": ("jump_after_unload", "log_creep", "slow_wander"),
    "time_delay": ("torque_bus_latency", "q_channel_lag", "u_channel_lag"),
    "hysteresis": ("preisach_relays", "duhem_envelope", "bouc_wen_n1_normalised"),
    "backlash": ("crisp_gap", "hyperbolic_soft_gap", "thermal_gap"),
    "asymmetric_friction": ("heavier_negative_coulomb", "steeper_positive_viscous",
                            "mirror_skew"),
    "periodic_disturbance": ("pump_pulsation", "beating_fan"),
    "position_dependent_stiffness": ("elliptic_2x", "sector_sigmoid"),
    "encoder_drift": ("q_saturating_creep", "u_root_creep"),
    "second_resonance": ("tip_mass_mode", "dyno_shaft_mode"),
}
OUT_OF_VOCABULARY: tuple[str, ...] = ("periodic_disturbance", "position_dependent_stiffness",
                                      "encoder_drift", "second_resonance")
UNSTATED_VOCABULARY: dict[str, str] = {
    "hysteresis": (
        "The output friction is a second-order Bliman–Sorine model: rate-independent, a "
        "function of the output path since the last reversal. After each reversal of q̇ the "
        "friction turns from ∓f_c to ±(1+ρ)·f_c over ≈ 1.8e-5 rad of output motion and relaxes "
        "to ±f_c over ≈ 1.2e-4 rad (ρ ≈ 0.12), so at every velocity reversal (scheme 3) the "
        "output stalls briefly while the motors wind the transmission and the residual "
        "against f_c·sgn(q̇) reaches ≈ 2·f_c for a fraction of a second; a hysteresis of the "
        "friction on the output angle, not of the transmission (which has none nominally)."),
    "time_delay": (
        "The torque transducer is followed by a 4th-order Bessel anti-alias filter whose DC "
        "group delay is SensorSpec.torque_filter_s (1.5 ms by default); its group delay is flat "
        "in band, so the torque reading lags the transmitted torque by that much. meta "
        "sensors.torque.lag_s states it (plus SensorSpec.torque_lag_s)."),
}

# --- constants ---------------------------------------------------------------------------------
G_ACC = 9.81
T_RATED = 120_000.0
TWIST_RATED_DEG = 0.50
W_TOP = 3000.0 * 2.0 * math.pi / 60.0 / REDUCTION
H_STEP = 1e-4
REC_EVERY = 4
REC_DT = H_STEP * REC_EVERY
LEAD_S, TAIL_S = 1.0, 1.0
START_T0, START_T1 = 0.1, 0.6
S1_HALF = 12.0
S1_PERIOD = 2 * S1_HALF
S2_RISE, S2_HOLD, S2_STEPS, S2_UNLOAD = 0.4, 2.0, 12, 5.0
S2_PERIOD = S2_STEPS * (S2_RISE + S2_HOLD) + S2_UNLOAD
S3_PERIOD = 20.0
TRAVEL_LIMIT = math.pi - 0.1
TAU_MAX = 250_000.0
GEAR_EFF = 0.9
OMEGA_C = 25.0
C_G, R_G, C_M, R_W, R_M = 1.5e5, 0.02, 2500.0, 1.2, 0.5
PHASES = ("idle", "load", "hold", "unload", "excite")

# effect sizes at scale 1 (data sheet section 5)
STR_EXP = (0.2, 3.0e-3, 0.8)
STR_PLATEAU = (0.2, 1.5e-3, 8.0e-3)
STR_SECH = (0.2, 3.0e-3)
LDF_DEADBAND = (0.02, 30_000.0)
LDF_VISC = 3.0
LDF_BACK = (0.015, 20.0)
TMP_SLOPE = 0.006
TMP_EXP = 0.012
GR_MESH = (5e-5, 72.0)
GR_MOTOR = 1.2e-5
GR_LOAD = (700.0, 48.0)
OFF_JUMP, OFF_JUMP_DROP = 700.0, 5000.0
OFF_LOG = (150.0, 5.0)
OFF_WANDER = (450.0, 150.0)
DELAY_TORQUE, DELAY_Q, DELAY_U = 5e-3, 8e-3, 6e-3
HYS_PREISACH, HYS_DUHEM, HYS_BW = 1500.0, 1200.0, 1000.0
HYS_DUHEM_LEN, HYS_BW_LEN = 0.12, 0.1
BACKLASH_B = 3e-4
BACKLASH_SOFT = 0.6
BACKLASH_TEMP = 0.025
ASYM_NEG_C = 0.25
ASYM_POS_V = 0.35
ASYM_SKEW = (0.12, 0.15)
PD_PUMP = (450.0, 1.7)
PD_FAN = (350.0, 0.9, 0.04)
PS_ELL = 0.08
PS_SECT = (0.07, 0.25)
DRIFT_Q = (2.5e-3, 60.0)
DRIFT_U = (2.0e-3, 100.0)
RES_TIP = (0.2, 14.0, 0.02)
RES_DYNO = (0.1, 20.0, 0.05)
N_RELAY = 64
VG220 = (220.0, 19.0)   # ISO VG 220 gear oil: cSt at 40 °C and 100 °C

FAMILIES = tuple(EFFECT_FORMS)
_FAMILY = {n: i for i, n in enumerate(FAMILIES)}
N_FAM = len(FAMILIES)


def _walther_coeffs() -> tuple[float, float]:
    """A, B of log10(log10(ν + 0.7)) = A − B·log10(T_K) through the ISO VG 220 points."""
    y1 = math.log10(math.log10(VG220[0] + 0.7))
    y2 = math.log10(math.log10(VG220[1] + 0.7))
    x1, x2 = math.log10(313.15), math.log10(373.15)
    b = (y1 - y2) / (x2 - x1)
    return y1 + b * x1, b


WALTHER_A, WALTHER_B = _walther_coeffs()


def walther_nu(temp_c: float) -> float:
    """Kinematic viscosity [cSt] of the gear oil at temp_c by Walther's law (data sheet 5)."""
    return 10.0 ** (10.0 ** (WALTHER_A - WALTHER_B * math.log10(temp_c + 273.15))) - 0.7


def _fourier_base() -> tuple[np.ndarray, np.ndarray]:
    """Eq. 12 velocity coefficients (a_l, b_l), l = 1..5, with q̇(0) = q̈(0) = 0 and
    max|q̇| = 0.9·ω_top."""
    a = np.array([0.0, 0.5, -0.3, 0.35, -0.25])
    b = np.array([0.0, 0.4, 0.3, -0.2, 0.15])
    ls = np.arange(1, 6)
    a[0] = -a[1:].sum()
    b[0] = -(ls[1:] * b[1:]).sum()
    wf = 2 * math.pi / S3_PERIOD
    tt = np.linspace(0.0, S3_PERIOD, 20001)
    v = (a[:, None] * np.cos(wf * ls[:, None] * tt) + b[:, None] * np.sin(wf * ls[:, None] * tt)).sum(0)
    k = 0.9 * W_TOP / np.abs(v).max()
    return a * k, b * k


FOURIER_A, FOURIER_B = _fourier_base()


def fourier_reference(t: np.ndarray | float) -> tuple[Any, Any, Any]:
    """qF(t) − qF(0), q̇F(t), q̈F(t) of the scheme-3 trajectory (direction +1, t from its start)."""
    t = np.asarray(t, dtype=float)
    wf = 2 * math.pi / S3_PERIOD
    pos = np.zeros_like(t)
    vel = np.zeros_like(t)
    acc = np.zeros_like(t)
    for i in range(5):
        lw = wf * (i + 1)
        a, b = FOURIER_A[i], FOURIER_B[i]
        pos += a / lw * np.sin(lw * t) - b / lw * (np.cos(lw * t) - 1.0)
        vel += a * np.cos(lw * t) + b * np.sin(lw * t)
        acc += -a * lw * np.sin(lw * t) + b * lw * np.cos(lw * t)
    return pos, vel, acc


def _bessel_modes(delay: float, h: float) -> tuple[np.ndarray, np.ndarray]:
    """Exact ZOH modal discretisation of the 4th-order Bessel low-pass with DC group delay
    `delay`: z_k ← a_k·z_k + g_k·x, y = Re Σ z_k."""
    poles = np.roots([1.0, 10.0, 45.0, 105.0, 105.0]) / delay
    den = np.poly(poles)
    res = np.array([den[-1] / np.prod([poles[k] - poles[j] for j in range(len(poles)) if j != k])
                    for k in range(len(poles))])
    a = np.exp(poles * h)
    g = res * (a - 1.0) / poles
    return a.astype(np.complex128), g.astype(np.complex128)


# --- sensors -----------------------------------------------------------------------------------

_SENSOR_RANGES = {
    "sample_rate_hz": (10.0, 1000.0), "encoder_res_deg": (1e-5, 1.0),
    "torque_noise": (0.0, 1e5), "torque_lag_s": (0.0, 1.0), "torque_filter_s": (0.0, 0.1),
    "torque_res": (0.0, 1e4), "load_noise": (0.0, 1e5), "load_res": (0.0, 1e4),
    "qd_noise": (0.0, 1.0), "motor_encoder_res": (0.0, 1e-2), "ud_noise": (0.0, 1.0),
    "current_noise": (0.0, 100.0), "temp_res": (0.0, 10.0), "temp_noise": (0.0, 10.0),
    "timing_jitter_s": (0.0, 1e-3),
}


@dataclass
class SensorSpec:
    """The bench's sensors (data sheet section 4); allowed ranges in _SENSOR_RANGES."""

    sample_rate_hz: float = 1000.0      # [Hz]
    encoder_res_deg: float = 0.01       # output encoder step [deg]
    torque_noise: float = 110.0         # white noise SD [N·m]
    torque_lag_s: float = 0.0           # pure lag of the torque reading [s]
    torque_filter_s: float = 1.5e-3     # Bessel (4th order) DC group delay [s] (0: no filter)
    torque_res: float = 500_000.0 / 2 ** 17   # ADC step [N·m] (0: none)
    load_noise: float = 80.0            # dynamometer torque noise SD [N·m]
    load_res: float = 5.0               # its step [N·m]
    qd_noise: float = 2e-5              # output velocity noise SD [rad/s]
    motor_encoder_res: float = 2 * math.pi / 2 ** 18 / REDUCTION  # referred step [rad]
    ud_noise: float = 4e-6              # referred motor velocity noise SD [rad/s]
    current_noise: float = 0.02         # current noise SD [A]
    temp_res: float = 0.1               # temperature step [°C]
    temp_noise: float = 0.03            # temperature noise SD [°C]
    timing_jitter_s: float = 2e-5       # bound of the uniform sampling-instant jitter [s]

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
            raise ValueError(f"effects[{name!r}]['scale'] must be <= SCALE_MAX = {SCALE_MAX:g}, "
                             f"got {s!r}")
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
    per = {1: S1_PERIOD, 2: S2_PERIOD, 3: S3_PERIOD}[int(scheme)]
    return LEAD_S + int(periods) * per + TAIL_S


def _travel(scheme: int, rpm: float, periods: int) -> float:
    w = rpm * 2.0 * math.pi / 60.0 / REDUCTION
    return w * (run_duration(scheme, periods) - 0.5 * (START_T0 + START_T1))


# --- the machine ---------------------------------------------------------------------------------

_SALT = 0xAF5EED
_NOMINAL: dict[str, tuple[float, float]] = {   # name: (value, relative SD)
    "I": (6685.166, 0.02), "mr_x": (20.779, 0.06), "mr_y": (-34.543, 0.06),
    "f_c": (2352.660, 0.02), "f_v": (8683.272, 0.03),
    "twist_rated": (math.radians(TWIST_RATED_DEG), 0.04), "stiff_ratio": (1.45, 0.04),
    "zeta_t": (0.30, 0.10), "bs_rho": (0.12, 0.10), "bs_eps": (1.2e-4, 0.10),
    "bs_eta": (0.15, 0.0), "J_m": (1.8e-3, 0.03), "F_mc": (1800.0, 0.05),
    "f_mv": (20000.0, 0.05), "kt1": (1.25, 0.02), "kt2": (1.25, 0.02), "kt3": (1.25, 0.02),
    "share1": (1 / 3, 0.02), "share2": (1 / 3, 0.02), "share3": (1 / 3, 0.02),
    "dyn_gain": (1.0, 0.003), "dyn_tau": (0.06, 0.10),
}


def draw_machine(seed: int) -> dict[str, float]:
    """The machine of campaign `seed` (data sheet section 1), with the derived values."""
    if not _is_int(seed) or int(seed) < 0:
        raise ValueError(f"seed must be an integer >= 0, got {seed!r}")
    rng = np.random.default_rng([_SALT, int(seed)])
    eps = np.clip(rng.standard_normal(len(_NOMINAL)), -2.5, 2.5)
    m = {k: float(v * (1.0 + sd * e)) for (k, (v, sd)), e in zip(_NOMINAL.items(), eps)}
    tot = m["share1"] + m["share2"] + m["share3"]
    for k in ("share1", "share2", "share3"):
        m[k] /= tot
    dr, rho = m["twist_rated"], m["stiff_ratio"]
    m["k0"] = T_RATED / (dr * (1.0 + (rho - 1.0) / 1.5))
    m["k_h"] = (rho - 1.0) * m["k0"] / (1.5 * math.sqrt(dr))
    m["c0"] = 2.0 * m["zeta_t"] * math.sqrt(m["k0"] * m["I"])
    m["J_M"] = 3.0 * m["J_m"] * REDUCTION ** 2
    m["gear_eff"] = GEAR_EFF
    return m


def compliance_torque(twist: np.ndarray | float, params: dict) -> np.ndarray:
    """Nominal elastic torque K(Δ) = k0·Δ + k_h·sgn(Δ)·|Δ|^1.5 [N·m] (data sheet section 2)."""
    d = np.asarray(twist, dtype=float)
    return params["k0"] * d + params["k_h"] * np.sign(d) * np.abs(d) ** 1.5


def twist_for(torque: float, params: dict) -> float:
    """The twist Δ with K(Δ) = torque (Newton on the monotone compliance law)."""
    d = torque / params["k0"]
    for _ in range(60):
        f = float(compliance_torque(d, params)) - torque
        fp = params["k0"] + 1.5 * params["k_h"] * math.sqrt(abs(d))
        step = f / fp
        d -= step
        if abs(step) < 1e-16:
            break
    return d


# --- the integration kernel ------------------------------------------------------------------

(P_I, P_MRX, P_MRY, P_FC, P_FV, P_DR, P_K0, P_KH, P_C0, P_RHO, P_EPS, P_ETA, P_JM, P_FMC,
 P_FMV, P_KT1, P_KT2, P_KT3, P_W1, P_W2, P_W3, P_DG, P_DT, P_SCHEME, P_DIR, P_OMEGA,
 P_PERIODS, P_AMB, P_FON, P_U0, P_FC_FF, P_FV_FF) = range(32)
N_P = 32

# state
(Y_Q, Y_QD, Y_U, Y_UD, Y_X1, Y_X2, Y_ZI, Y_TD, Y_TG, Y_TM1, Y_TM2, Y_TM3, Y_HS, Y_Q2,
 Y_Q2D) = range(15)
N_Y = 15
# aux / record columns
(A_T, A_TL, A_TC, A_FF, A_G, A_DIST, A_TM, A_H, A_PH, A_QDD, A_I1, A_I2, A_I3) = range(13)
N_A = 13
(RC_Q, RC_QD, RC_QDD, RC_U, RC_UD, RC_T, RC_TS, RC_TL, RC_TC, RC_FF, RC_G, RC_DIST, RC_TM,
 RC_TG, RC_TM1, RC_TM2, RC_TM3, RC_H, RC_PH, RC_I1, RC_I2, RC_I3) = range(22)
N_RC = 22

(F_STR, F_LDF, F_TMP, F_GR, F_OFF, F_DEL, F_HYS, F_BL, F_ASY, F_PD, F_PS, F_DR, F_RES) = range(13)


@nb.njit(cache=True)
def _ramp_int(t):
    """∫ of the raised-cosine speed ramp (0 → 1 over START_T0..START_T1), its value, its rate."""
    t0, t1 = START_T0, START_T1
    if t <= t0:
        return 0.0, 0.0, 0.0
    if t >= t1:
        return 0.5 * (t1 - t0) + (t - t1), 1.0, 0.0
    d = t1 - t0
    x = math.pi * (t - t0) / d
    return (0.5 * (t - t0) - d / (2 * math.pi) * math.sin(x), 0.5 * (1 - math.cos(x)),
            0.5 * math.sin(x) * math.pi / d)


@nb.njit(cache=True)
def _profile(t, p, fa, fb):
    """u_ref − u0, u̇_ref, ü_ref, torque command, phase code."""
    scheme = int(p[P_SCHEME])
    dirn = p[P_DIR]
    nper = p[P_PERIODS]
    if scheme == 3:
        tl = t - LEAD_S
        if tl <= 0.0 or tl >= nper * S3_PERIOD:
            tl = 0.0 if tl <= 0.0 else nper * S3_PERIOD
            ph = 0.0
        else:
            ph = 4.0
        wf = 2 * math.pi / S3_PERIOD
        pos = 0.0
        vel = 0.0
        acc = 0.0
        for i in range(5):
            lw = wf * (i + 1)
            pos += fa[i] / lw * math.sin(lw * tl) - fb[i] / lw * (math.cos(lw * tl) - 1.0)
            vel += fa[i] * math.cos(lw * tl) + fb[i] * math.sin(lw * tl)
            acc += -fa[i] * lw * math.sin(lw * tl) + fb[i] * lw * math.cos(lw * tl)
        if ph == 0.0:
            vel = 0.0
            acc = 0.0
        return dirn * pos, dirn * vel, dirn * acc, 0.0, ph
    w = p[P_OMEGA]
    ri, rv, ra = _ramp_int(t)
    pos, vel, acc = dirn * w * ri, dirn * w * rv, dirn * w * ra
    tl = t - LEAD_S
    cmd = 0.0
    ph = 0.0
    if tl > 0.0:
        per = S1_PERIOD if scheme == 1 else S2_PERIOD
        k = math.floor(tl / per)
        if k < nper:
            tau = tl - k * per
            if scheme == 1:
                if tau < S1_HALF:
                    cmd = T_RATED * tau / S1_HALF
                    ph = 1.0
                else:
                    cmd = T_RATED * (S1_PERIOD - tau) / S1_HALF
                    ph = 3.0
            else:
                st = S2_RISE + S2_HOLD
                j = math.floor(tau / st)
                step = T_RATED / S2_STEPS
                if j < S2_STEPS:
                    r = tau - j * st
                    if r < S2_RISE:
                        cmd = step * (j + r / S2_RISE)
                        ph = 1.0
                    else:
                        cmd = step * (j + 1)
                        ph = 2.0
                else:
                    r = tau - S2_STEPS * st
                    cmd = T_RATED * max(0.0, 1.0 - r / S2_UNLOAD)
                    ph = 3.0
    return pos, vel, acc, cmd, ph


@nb.njit(cache=True)
def _sgn(x):
    return 1.0 if x > 0.0 else (-1.0 if x < 0.0 else 0.0)


@nb.njit(cache=True)
def _deriv(t, y, p, ef, es, fa, fb, wand, h_pre, dy, aux):
    """Right-hand side of the data sheet's ODEs; fills dy and aux."""
    q, qd, u, ud = y[Y_Q], y[Y_QD], y[Y_U], y[Y_UD]
    th = y[Y_TG]
    fc, fv, dr = p[P_FC], p[P_FV], p[P_DR]
    uref, vref, aref, cmd, ph = _profile(t, p, fa, fb)
    uref += p[P_U0]

    # --- transmission
    d_raw = u - q
    dd = ud - qd
    d = d_raw
    if ef[F_GR] == 0:
        z = GR_MESH[1]
        d -= es[F_GR] * GR_MESH[0] * (math.sin(z * q) + 0.35 * math.sin((z - 1) * q + 0.4)
                                      + 0.35 * math.sin((z + 1) * q + 1.1))
    elif ef[F_GR] == 1:
        th_m = REDUCTION * u
        d -= es[F_GR] * GR_MOTOR * (math.sin(th_m + 0.3) + 0.6 * math.sin(3 * th_m + 1.2))
    dz = d
    dzp = 1.0
    if ef[F_BL] >= 0:
        b = es[F_BL] * BACKLASH_B
        if ef[F_BL] == 2:
            b *= 1.0 + BACKLASH_TEMP * (th - 25.0)
            b = max(b, 0.0)
        if ef[F_BL] == 1:
            e = BACKLASH_SOFT * b
            a1 = d - b
            a2 = d + b
            s1 = math.sqrt(a1 * a1 + e * e)
            s2 = math.sqrt(a2 * a2 + e * e)
            dz = 0.5 * (a1 + s1) + 0.5 * (a2 - s2)
            dzp = 0.5 * (1 + a1 / s1) + 0.5 * (1 - a2 / s2)
        else:
            if d > b:
                dz = d - b
            elif d < -b:
                dz = d + b
            else:
                dz = 0.0
                dzp = 0.0
    kel = p[P_K0] * dz + p[P_KH] * _sgn(dz) * abs(dz) ** 1.5
    mult = 1.0
    if ef[F_PS] == 0:
        mult = 1.0 + PS_ELL * es[F_PS] * math.cos(2 * q + 0.3)
    elif ef[F_PS] == 1:
        mult = 1.0 + PS_SECT[0] * es[F_PS] * q / math.sqrt(q * q + PS_SECT[1] ** 2)
    mult = max(mult, 0.2)
    T = mult * kel + p[P_C0] * (1.0 + abs(dz) / dr) * dzp * dd
    # hysteresis
    hy = 0.0
    dhs = 0.0
    if ef[F_HYS] == 0:
        hy = h_pre
    elif ef[F_HYS] == 1:
        hy = y[Y_HS]
        ln = HYS_DUHEM_LEN * dr
        dhs = abs(dd) / ln * (es[F_HYS] * HYS_DUHEM * _sgn(dd) / (1.0 + (d_raw / dr) ** 2) - hy)
    elif ef[F_HYS] == 2:
        zz = y[Y_HS]
        hy = es[F_HYS] * HYS_BW * zz
        dhs = (dd - 0.5 * abs(dd) * zz - 0.5 * dd * abs(zz)) / (HYS_BW_LEN * dr)
    T += hy
    if ef[F_GR] == 2:
        T += es[F_GR] * GR_LOAD[0] * (0.25 + abs(kel) / T_RATED) * math.sin(GR_LOAD[1] * q + 0.5)

    # --- friction level and viscous slope
    sv = _sgn(qd)
    av = abs(qd)
    L = fc
    fvel = fv
    if ef[F_STR] == 0:
        L += es[F_STR] * STR_EXP[0] * fc * math.exp(-(av / STR_EXP[1]) ** STR_EXP[2])
    elif ef[F_STR] == 1:
        L += es[F_STR] * STR_PLATEAU[0] * fc * min(1.0, max(0.0, (STR_PLATEAU[2] - av)
                                                          / (STR_PLATEAU[2] - STR_PLATEAU[1])))
    elif ef[F_STR] == 2:
        L += es[F_STR] * STR_SECH[0] * fc / math.cosh(min(av / STR_SECH[1], 300.0))
    dvis = 0.0
    if ef[F_LDF] == 0:
        L += es[F_LDF] * LDF_DEADBAND[0] * max(abs(T) - LDF_DEADBAND[1], 0.0)
    elif ef[F_LDF] == 1:
        dvis += es[F_LDF] * LDF_VISC * abs(T) / T_RATED * fv
    elif ef[F_LDF] == 2:
        pw = T * qd
        bk = 0.5 * (1.0 - pw / math.sqrt(pw * pw + LDF_BACK[1] ** 2))
        L += es[F_LDF] * LDF_BACK[0] * abs(T) * bk
    if ef[F_TMP] == 0:
        tk = th + 273.15
        nu = 10.0 ** (10.0 ** (WALTHER_A - WALTHER_B * math.log10(tk))) - 0.7
        tk0 = 25.0 + 273.15
        nu0 = 10.0 ** (10.0 ** (WALTHER_A - WALTHER_B * math.log10(tk0))) - 0.7
        dvis += es[F_TMP] * (math.sqrt(nu / nu0) - 1.0) * fv
    elif ef[F_TMP] == 1:
        L += -es[F_TMP] * TMP_SLOPE * (th - 25.0) * fc
    elif ef[F_TMP] == 2:
        e = math.exp(-TMP_EXP * (th - 25.0)) - 1.0
        L += es[F_TMP] * e * fc
        dvis += es[F_TMP] * e * fv
    if ef[F_ASY] == 0:
        if qd < 0.0:
            L *= 1.0 + ASYM_NEG_C * es[F_ASY]
    elif ef[F_ASY] == 1:
        if qd > 0.0:
            fvel *= 1.0 + ASYM_POS_V * es[F_ASY]
    elif ef[F_ASY] == 2:
        if qd > 0.0:
            L *= 1.0 + ASYM_SKEW[0] * es[F_ASY]
            fvel *= 1.0 - ASYM_SKEW[1] * es[F_ASY]
        elif qd < 0.0:
            L *= 1.0 - ASYM_SKEW[0] * es[F_ASY]
            fvel *= 1.0 + ASYM_SKEW[1] * es[F_ASY]
    L = max(L, 0.0)
    rho, eps, eta = p[P_RHO], p[P_EPS], p[P_ETA]
    x1, x2 = y[Y_X1], y[Y_X2]
    dx1 = (qd * (1.0 + rho) * L - av * x1) / (eta * eps)
    dx2 = (-qd * rho * L - av * x2) / eps
    Ff = x1 + x2 + (fvel + dvis) * qd

    grav = G_ACC * (p[P_MRX] * math.sin(q) + p[P_MRY] * math.cos(q))

    # --- dynamometer and disturbances
    dyn = y[Y_TD]
    ddyn = (p[P_DG] * cmd - dyn) / p[P_DT]
    wsum = 0.0
    for j in range(wand.shape[0]):
        wsum += wand[j, 0] * math.sin(wand[j, 1] * t + wand[j, 2])
    tauL = dyn + wsum * abs(cmd) / T_RATED
    dist = 0.0
    if ef[F_PD] == 0:
        dist = es[F_PD] * PD_PUMP[0] * (math.sin(2 * math.pi * PD_PUMP[1] * t)
                                        + 0.4 * math.sin(4 * math.pi * PD_PUMP[1] * t + 1.0))
    elif ef[F_PD] == 1:
        dist = es[F_PD] * PD_FAN[0] * math.sin(2 * math.pi * PD_FAN[1] * t) * (
            1.0 + 0.6 * math.sin(2 * math.pi * PD_FAN[2] * t))
    load_on_q = tauL
    dq2 = 0.0
    dq2d = 0.0
    if ef[F_RES] == 0:
        i2 = es[F_RES] * RES_TIP[0] * p[P_I]
        w2 = 2 * math.pi * RES_TIP[1]
        k2 = i2 * w2 * w2
        c2 = 2 * RES_TIP[2] * math.sqrt(k2 * i2)
        ts = k2 * (q - y[Y_Q2]) + c2 * (qd - y[Y_Q2D])
        load_on_q = tauL + ts
        dq2 = y[Y_Q2D]
        dq2d = ts / i2
    elif ef[F_RES] == 1:
        i2 = es[F_RES] * RES_DYNO[0] * p[P_I]
        w2 = 2 * math.pi * RES_DYNO[1]
        k2 = i2 * w2 * w2
        c2 = 2 * RES_DYNO[2] * math.sqrt(k2 * i2)
        ts = k2 * (q - y[Y_Q2]) + c2 * (qd - y[Y_Q2D])
        load_on_q = ts
        tauL = ts
        dq2 = y[Y_Q2D]
        dq2d = (ts - (dyn + wsum * abs(cmd) / T_RATED)) / i2

    qdd = (T - load_on_q - grav - Ff - dist) / p[P_I]

    # --- motors and controller
    kp = OMEGA_C / 5.0
    jm = p[P_JM]
    kv = jm * OMEGA_C
    ki = kv * OMEGA_C / 5.0
    vstar = vref + kp * (uref - u)
    ev = vstar - ud
    sref = vref / math.sqrt(vref * vref + 1e-8)
    taum = (jm * aref + kv * ev + ki * y[Y_ZI] + cmd + p[P_FC_FF] * sref + p[P_FV_FF] * vref)
    taum = min(max(taum, -TAU_MAX), TAU_MAX)
    fm = p[P_FMC] * ud / math.sqrt(ud * ud + 1e-8) + p[P_FMV] * ud
    udd = (taum - T - fm) / jm
    den = REDUCTION * GEAR_EFF
    i1 = p[P_W1] * taum / (p[P_KT1] * den)
    i2c = p[P_W2] * taum / (p[P_KT2] * den)
    i3 = p[P_W3] * taum / (p[P_KT3] * den)

    amb = p[P_AMB]
    dy[Y_Q] = qd
    dy[Y_QD] = qdd
    dy[Y_U] = ud
    dy[Y_UD] = udd
    dy[Y_X1] = dx1
    dy[Y_X2] = dx2
    dy[Y_ZI] = ev
    dy[Y_TD] = ddyn
    dy[Y_TG] = (abs(Ff * qd) + abs(fm * ud) - (th - amb) / R_G) / C_G
    dy[Y_TM1] = (R_W * i1 * i1 - (y[Y_TM1] - amb) / R_M) / C_M
    dy[Y_TM2] = (R_W * i2c * i2c - (y[Y_TM2] - amb) / R_M) / C_M
    dy[Y_TM3] = (R_W * i3 * i3 - (y[Y_TM3] - amb) / R_M) / C_M
    dy[Y_HS] = dhs
    dy[Y_Q2] = dq2
    dy[Y_Q2D] = dq2d

    aux[A_T] = T
    aux[A_TL] = tauL
    aux[A_TC] = cmd
    aux[A_FF] = Ff
    aux[A_G] = grav
    aux[A_DIST] = dist
    aux[A_TM] = taum
    aux[A_H] = hy
    aux[A_PH] = ph
    aux[A_QDD] = qdd
    aux[A_I1] = i1
    aux[A_I2] = i2c
    aux[A_I3] = i3


@nb.njit(cache=True)
def _integrate(p, ef, es, fa, fb, wand, relc, relw, y0, nrec, bz_a, bz_g):
    """ABM4 PECE at H_STEP from y0; a record (N_RC columns) every REC_EVERY steps."""
    rec = np.zeros((nrec, N_RC))
    y = y0.copy()
    hist = np.zeros((4, N_Y))        # f_n, f_{n-1}, f_{n-2}, f_{n-3}
    dy = np.zeros(N_Y)
    aux = np.zeros(N_A)
    yp = np.zeros(N_Y)
    nrel = relc.shape[0]
    relay = np.zeros(nrel)
    hscale = es[F_HYS] * HYS_PREISACH
    d0 = y[Y_U] - y[Y_Q]
    for i in range(nrel):
        relay[i] = 1.0 if d0 >= relc[i] else -1.0
    h_pre = 0.0
    if ef[F_HYS] == 0 and nrel > 0:
        h_pre = -hscale * relay.sum() / nrel
    nb_ = bz_a.shape[0]
    bz = np.zeros(nb_, dtype=np.complex128)
    use_f = p[P_FON] > 0.0
    t = 0.0
    _deriv(t, y, p, ef, es, fa, fb, wand, h_pre, dy, aux)
    # filter at steady state on the initial torque
    if use_f:
        for k in range(nb_):
            bz[k] = bz_g[k] * aux[A_T] / (1.0 - bz_a[k])
    for k in range(4):
        hist[k, :] = dy
    nsteps = (nrec - 1) * REC_EVERY
    ts_now = aux[A_T]

    # record 0
    rec[0, RC_Q] = y[Y_Q]
    rec[0, RC_QD] = y[Y_QD]
    rec[0, RC_QDD] = aux[A_QDD]
    rec[0, RC_U] = y[Y_U]
    rec[0, RC_UD] = y[Y_UD]
    rec[0, RC_T] = aux[A_T]
    rec[0, RC_TS] = ts_now
    rec[0, RC_TL] = aux[A_TL]
    rec[0, RC_TC] = aux[A_TC]
    rec[0, RC_FF] = aux[A_FF]
    rec[0, RC_G] = aux[A_G]
    rec[0, RC_DIST] = aux[A_DIST]
    rec[0, RC_TM] = aux[A_TM]
    rec[0, RC_TG] = y[Y_TG]
    rec[0, RC_TM1] = y[Y_TM1]
    rec[0, RC_TM2] = y[Y_TM2]
    rec[0, RC_TM3] = y[Y_TM3]
    rec[0, RC_H] = aux[A_H]
    rec[0, RC_PH] = aux[A_PH]
    rec[0, RC_I1] = aux[A_I1]
    rec[0, RC_I2] = aux[A_I2]
    rec[0, RC_I3] = aux[A_I3]
    h = H_STEP
    for n in range(nsteps):
        tq_in = aux[A_T]
        for j in range(N_Y):
            yp[j] = y[j] + h / 24.0 * (55.0 * hist[0, j] - 59.0 * hist[1, j]
                                       + 37.0 * hist[2, j] - 9.0 * hist[3, j])
        t = (n + 1) * h
        _deriv(t, yp, p, ef, es, fa, fb, wand, h_pre, dy, aux)
        for j in range(N_Y):
            y[j] = y[j] + h / 24.0 * (9.0 * dy[j] + 19.0 * hist[0, j] - 5.0 * hist[1, j]
                                      + hist[2, j])
        # discrete parts: relays
        if ef[F_HYS] == 0:
            d = y[Y_U] - y[Y_Q]
            for i in range(nrel):
                if d >= relc[i] + relw[i]:
                    relay[i] = 1.0
                elif d <= relc[i] - relw[i]:
                    relay[i] = -1.0
            h_pre = -hscale * relay.sum() / nrel
        _deriv(t, y, p, ef, es, fa, fb, wand, h_pre, dy, aux)
        for j in range(N_Y):
            hist[3, j] = hist[2, j]
            hist[2, j] = hist[1, j]
            hist[1, j] = hist[0, j]
            hist[0, j] = dy[j]
        # torque filter (ZOH on the torque over the step)
        if use_f:
            acc = 0.0
            for k in range(nb_):
                bz[k] = bz_a[k] * bz[k] + bz_g[k] * tq_in
                acc += bz[k].real
            ts_now = acc
        else:
            ts_now = aux[A_T]
        if (n + 1) % REC_EVERY == 0:
            r = (n + 1) // REC_EVERY
            rec[r, RC_Q] = y[Y_Q]
            rec[r, RC_QD] = y[Y_QD]
            rec[r, RC_QDD] = aux[A_QDD]
            rec[r, RC_U] = y[Y_U]
            rec[r, RC_UD] = y[Y_UD]
            rec[r, RC_T] = aux[A_T]
            rec[r, RC_TS] = ts_now
            rec[r, RC_TL] = aux[A_TL]
            rec[r, RC_TC] = aux[A_TC]
            rec[r, RC_FF] = aux[A_FF]
            rec[r, RC_G] = aux[A_G]
            rec[r, RC_DIST] = aux[A_DIST]
            rec[r, RC_TM] = aux[A_TM]
            rec[r, RC_TG] = y[Y_TG]
            rec[r, RC_TM1] = y[Y_TM1]
            rec[r, RC_TM2] = y[Y_TM2]
            rec[r, RC_TM3] = y[Y_TM3]
            rec[r, RC_H] = aux[A_H]
            rec[r, RC_PH] = aux[A_PH]
            rec[r, RC_I1] = aux[A_I1]
            rec[r, RC_I2] = aux[A_I2]
            rec[r, RC_I3] = aux[A_I3]
    return rec


def _relays(dr: float) -> tuple[np.ndarray, np.ndarray]:
    c = np.linspace(-0.9, 0.9, 8) * dr
    w = np.linspace(0.04, 0.5, 8) * dr
    cc, ww = np.meshgrid(c, w, indexing="ij")
    return cc.ravel().copy(), ww.ravel().copy()


def _quant(x: np.ndarray, step: float) -> np.ndarray:
    return x if step <= 0.0 else np.round(x / step) * step


# --- a run ------------------------------------------------------------------------------------

def simulate_run(scheme: int, motor_speed_rpm: float | None, direction: int, temp_joint_c: float,
                 effects: dict[str, dict] | None = None, *, sensors: SensorSpec | None = None,
                 periods: int = 3, seed: int, run: int) -> RigRun:
    """One bench run of rig AF (see the module data sheet). `seed` is the campaign (it draws the
    machine), `run` the run within it (it draws the noise, the jitter and the dynamometer's
    wander)."""
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
    p[P_DR], p[P_K0], p[P_KH], p[P_C0] = m["twist_rated"], m["k0"], m["k_h"], m["c0"]
    p[P_RHO], p[P_EPS], p[P_ETA] = m["bs_rho"], m["bs_eps"], m["bs_eta"]
    p[P_JM], p[P_FMC], p[P_FMV] = m["J_M"], m["F_mc"], m["f_mv"]
    p[P_KT1], p[P_KT2], p[P_KT3] = m["kt1"], m["kt2"], m["kt3"]
    p[P_W1], p[P_W2], p[P_W3] = m["share1"], m["share2"], m["share3"]
    p[P_DG], p[P_DT] = m["dyn_gain"], m["dyn_tau"]
    p[P_SCHEME], p[P_DIR] = scheme, dirn
    p[P_OMEGA] = 0.0 if rpm is None else rpm * 2.0 * math.pi / 60.0 / REDUCTION
    p[P_PERIODS], p[P_AMB] = periods, amb
    p[P_FC_FF] = 2352.660 + 1800.0
    p[P_FV_FF] = 8683.272 + 20000.0
    if sens.torque_filter_s > 0.0:
        bz_a, bz_g = _bessel_modes(sens.torque_filter_s, H_STEP)
        p[P_FON] = 1.0
    else:
        bz_a = np.zeros(4, dtype=np.complex128)
        bz_g = np.zeros(4, dtype=np.complex128)

    # the dynamometer's wander (per run)
    rw = np.random.default_rng([_SALT, seed, run, 1])
    nu = rw.uniform(0.03, 0.4, 3)
    phs = rw.uniform(0.0, 2 * math.pi, 3)
    amp = rw.uniform(0.5, 1.0, 3)
    amp *= 250.0 / math.sqrt(0.5 * np.sum(amp ** 2))
    wand = np.column_stack([amp, 2 * math.pi * nu, phs])

    # initial state: at rest at q = 0, the transmission holds gravity
    g0 = G_ACC * m["mr_y"]
    d0 = twist_for(g0, m)
    if "backlash" in eff:
        b = BACKLASH_B * scale("backlash")
        if form("backlash") == "thermal_gap":
            b *= max(1.0 + BACKLASH_TEMP * (amb - 25.0), 0.0)
        d0 += b * math.copysign(1.0, g0)
    if form("position_dependent_stiffness") is not None:
        d0 = twist_for(g0 / _ps_mult(form("position_dependent_stiffness"),
                                     scale("position_dependent_stiffness"), 0.0), m) + \
            (d0 - twist_for(g0, m))
    p[P_U0] = d0
    y0 = np.zeros(N_Y)
    y0[Y_U] = d0
    y0[Y_TD] = 0.0
    y0[Y_TG] = y0[Y_TM1] = y0[Y_TM2] = y0[Y_TM3] = amb
    kv = m["J_M"] * OMEGA_C
    y0[Y_ZI] = g0 / (kv * OMEGA_C / 5.0)
    relc, relw = _relays(m["twist_rated"]) if form("hysteresis") == "preisach_relays" else (
        np.zeros(0), np.zeros(0))

    nrec = int(math.ceil(duration / REC_DT)) + 1
    rec = _integrate(p, ef, es, FOURIER_A, FOURIER_B, wand, relc, relw, y0, nrec, bz_a, bz_g)
    if not np.all(np.isfinite(rec)):
        raise RuntimeError("rig_af: the integration diverged")
    tr = np.arange(nrec) * REC_DT

    # sample instants with jitter
    n = int(math.floor(duration * fs + 1e-9)) + 1
    rj = np.random.default_rng([_SALT, seed, run, 3])
    jit = min(sens.timing_jitter_s, 0.25 / fs)
    t = np.arange(n) / fs + jit * rj.uniform(-1.0, 1.0, n)
    t[0] = 0.0
    t[-1] = min(t[-1], (n - 1) / fs)
    t = t[t <= tr[-1]]
    n = len(t)

    def at(col: int, lag: float = 0.0) -> np.ndarray:
        return np.interp(t - lag, tr, rec[:, col])

    truth = pd.DataFrame({
        "t": t, "q": at(RC_Q), "qd": at(RC_QD), "qdd": at(RC_QDD), "u": at(RC_U), "ud": at(RC_UD),
        "twist": at(RC_U) - at(RC_Q), "twist_rate": at(RC_UD) - at(RC_QD), "torque": at(RC_T),
        "torque_sensor": at(RC_TS), "torque_load": at(RC_TL), "torque_cmd": at(RC_TC),
        "friction": at(RC_FF), "gravity": at(RC_G), "disturbance": at(RC_DIST),
        "motor_torque": at(RC_TM), "temp_joint": at(RC_TG), "temp_m1": at(RC_TM1),
        "temp_m2": at(RC_TM2), "temp_m3": at(RC_TM3), "hysteresis": at(RC_H),
    })

    # --- noise, always drawn in the same order (independent of the effects)
    rng = np.random.default_rng([_SALT, seed, run, 2])
    nz = {k: rng.standard_normal(n) for k in (
        "torque", "load", "qd", "ud", "i1", "i2", "i3", "w1", "w2", "w3",
        "tm1", "tm2", "tm3", "tg")}

    # --- readings
    dl = form("time_delay")
    q_lag = DELAY_Q * scale("time_delay") if dl == "q_channel_lag" else 0.0
    u_lag = DELAY_U * scale("time_delay") if dl == "u_channel_lag" else 0.0
    t_lag = DELAY_TORQUE * scale("time_delay") if dl == "torque_bus_latency" else 0.0
    q_true = at(RC_Q, q_lag)
    if form("encoder_drift") == "q_saturating_creep":
        q_true = q_true + DRIFT_Q[0] * scale("encoder_drift") * (1.0 - np.exp(-t / DRIFT_Q[1]))
    u_true = at(RC_U, u_lag)
    if form("encoder_drift") == "u_root_creep":
        u_true = u_true + DRIFT_U[0] * scale("encoder_drift") * np.sqrt(t / DRIFT_U[1])
    q_res = math.radians(sens.encoder_res_deg)
    q_meas = _quant(q_true, q_res)
    u_meas = _quant(u_true, sens.motor_encoder_res)
    qd_meas = at(RC_QD, q_lag) + sens.qd_noise * nz["qd"]
    ud_true = at(RC_UD, u_lag)
    ud_meas = ud_true + sens.ud_noise * nz["ud"]

    torque = at(RC_TS, sens.torque_lag_s + t_lag)
    off = form("torque_offset")
    if off == "jump_after_unload":
        tt = rec[:, RC_T]
        drop = np.maximum.accumulate(tt) - tt >= OFF_JUMP_DROP
        on = np.zeros(n)
        if drop.any():
            t_on = tr[int(np.flatnonzero(drop)[0])]
            on = (t >= t_on).astype(float)
        torque = torque + OFF_JUMP * scale("torque_offset") * on
    elif off == "log_creep":
        torque = torque + OFF_LOG[0] * scale("torque_offset") * np.log1p(t / OFF_LOG[1])
    elif off == "slow_wander":
        torque = torque + OFF_WANDER[0] * scale("torque_offset") * np.sin(
            2 * math.pi * t / OFF_WANDER[1])
    torque = _quant(torque + sens.torque_noise * nz["torque"], sens.torque_res)
    tload = _quant(at(RC_TL) + sens.load_noise * nz["load"], sens.load_res)

    cols: dict[str, Any] = {"t": t, "q": q_meas, "qd": qd_meas, "u": u_meas, "ud": ud_meas,
                            "torsion": q_meas - u_meas, "torque": torque, "torque_load": tload,
                            "torque_cmd": at(RC_TC)}
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
        "started_at": "2026-03-03T07:45:00Z",
        "notes": (f"{RIG_NAME} validation simulator, scheme {scheme}, {periods} period(s), "
                  f"joint at {amb:g} °C"),
        "timing_jitter_s": jit,
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
            **{f"w_m{k}": {"noise_sd": REDUCTION * sens.ud_noise} for k in (1, 2, 3)},
            **{f"temp_m{k}": {"resolution": sens.temp_res, "noise_sd": sens.temp_noise}
               for k in (1, 2, 3)},
            "temp_joint": {"resolution": sens.temp_res, "noise_sd": sens.temp_noise},
        },
    }
    params = dict(m)
    params.update({"effects": {k: {"form": f, "scale": s} for k, (f, s) in eff.items()},
                   "duration_s": duration, "seed": seed, "run": run})
    return RigRun(samples=samples, meta=meta, truth=truth, params=params)


def _ps_mult(form: str | None, s: float, q: float) -> float:
    """The position-dependent stiffness multiplier (data sheet 5) at angle q."""
    if form == "elliptic_2x":
        mlt = 1.0 + PS_ELL * s * math.cos(2 * q + 0.3)
    elif form == "sector_sigmoid":
        mlt = 1.0 + PS_SECT[0] * s * q / math.sqrt(q * q + PS_SECT[1] ** 2)
    else:
        mlt = 1.0
    return max(mlt, 0.2)
