"""Validation rig X: an independently written simulator of a J4 joint test bench (CFETR CMOR,
4th joint, three motors, reduction N = 11 000, rated 120 kN·m), for scoring a sim-to-real
diagnosis blind. SI units throughout (temperatures in °C). Angles of the drive train are referred
to the joint output (angle / N) unless said otherwise.

Data sheet
==========

Machine (nominal values; each campaign seed draws its own machine with a small spread, given)
------------------------------------------------------------------------------------------------
Output body (paper Eq. 4, Table 3):
    I·q̈ = T − τ_L − g·(mr_x·sin q + mr_y·cos q) − f_v·q̇ − F_BS − (body disturbances)
    I = 6685.166 kg·m² (±1 %), mr_x = 20.779 kg·m (±2 %), mr_y = −34.543 kg·m (±2 %),
    f_v = 8683.272 N·m·s/rad (±1 %), f_c = 2352.660 N·m (±1 %), g = 9.81 m/s².
Output friction: Bliman–Sorine second-order model (1995), rate independent, driven by the output
    displacement s (ds = |dq|):  dx1/ds = (f1·sgn q̇ − x1)/(η·ε),  dx2/ds = (−f2·sgn q̇ − x2)/ε,
    F_BS = x1 + x2;  steady sliding F_BS = (f1 − f2)·sgn q̇ = f_c·sgn q̇;  f1 = 1.35·f_c,
    f2 = 0.35·f_c, η = 0.15, ε = 5e-5 rad (±5 %).  After a reversal the friction overshoots the
    Coulomb level (stiction peak ≈ 1.34·f_c after ≈ 0.6·ε of travel from full reverse sliding),
    and presliding is elastic-like with stiffness f1/(η·ε) − f2/ε ≈ 4.1e8 N·m/rad.  Viscous
    f_v·q̇ on top.
Transmission (carrier of the first stage → output), a mildly SOFTENING rational law plus damping:
    T_el = k0·Δ/(1 + |Δ|/Δs),  Δ = θ_g − q,  k0 = 1.471e7 N·m/rad (±3 %), Δs = 0.1247 rad;
    T = T_el + D·Δ̇ (+ hysteresis torque), D = 1.2e5 N·m·s/rad.
    At 120 kN·m: Δ = 8.73e-3 rad, secant 1.375e7 N·m/rad, tangent 0.873·k0 (12.7 % below k0).
    The recorded twist (motor-1 angle/N − q) adds motor 1's pinion deflection (≈ 1e-4 rad at
    rated load): total ≈ 8.8e-3 rad ≈ 0.51° at 120 kN·m (the paper's "about half a degree").
Drive: 3 motors (referred inertia J_m·N² = 7.26e4 kg·m² each, motor-side viscous 2e3 N·m·s/rad
    referred), each through its own pinion compliance k_p = 4e8 N·m/rad, c_p = 6e5 N·m·s/rad
    (referred) into the first-stage carrier (J_g = 3e4 kg·m²).  Master–slave: motor 1 closes a PI
    speed loop on its own speed (K_p = 3.7e6 N·m·s/rad, K_i = 1.1e7 N·m/rad, plus acceleration
    feed-forward); motors 2 and 3 follow motor 1's torque command with a gain mismatch m_2, m_3
    (drawn ±2 %) and a speed droop 2e5 N·m·s/rad·(ω_j − ω_1); each motor's torque follows its
    command through a current loop (first order, 1 ms).  k_t = 1.2 N·m/A, winding 1.2 Ω.
Loader (regenerative, back-to-back load gearbox): the load cell sits on the load shaft
    (k_L = 2.5e7 N·m/rad, c_L = 1e5 N·m·s/rad) to the load gearbox (J_L = 1.5e4 kg·m², viscous
    3e3 N·m·s/rad, referred); the load motor is torque controlled: first-order torque loop (5 ms)
    on the command τ_cmd + 0.3·(τ_cmd − τ_L) + 3 s⁻¹·∫(τ_cmd − τ_L)dt.  τ_L is the shaft torque
    on the joint output (positive = the paper's positive loading).
Thermal: motor windings C = 2000 J/K, 0.5 K/W to ambient 22 °C, 4 K/W to the gearbox; gearbox
    C = 2e4 J/K, 0.05 K/W to ambient, heated by the friction power and 3 % of the transmitted
    power; explicit update at each sample.  temp_joint_c is the gearbox temperature at t = 0; the
    windings start 2 °C above it.
Integrator: Alexander's 2-stage L-stable SDIRK (order 2, γ = 1 − 1/√2), modified Newton with a
    finite-difference Jacobian (refreshed every 8 steps, on slow convergence, or on failure, with
    step splitting on failure), inner step ≤ 0.5 ms dividing the sample interval exactly, numba.

Schemes (paper section II-B; output speed = motor speed·2π/60/N)
----------------------------------------------------------------
1: 70 s at constant motor speed (1 s smooth ramp-up): idle 0–5 s, load ramp 0 → 120 kN·m over
   5–35 s, unload 35–65 s, idle 65–70 s.  Load always positive, motion in `direction`.
2: 64 s: idle 2 s, 12 × (1 s ramp of +10 kN·m "load", 2 s "hold") to 120 kN·m, then
   12 × (1 s ramp of −10 kN·m "unload", 1 s "hold"), idle 2 s.
3: Eq. 12 Fourier excitation, 5 harmonics, period 20 s, `periods` periods, q̇(0) = q̈(0) = 0,
   peak output speed 0.9·3000 r/min / N; motor 1 tracks the speed profile (direction = sense);
   the loader holds a zero torque set point.  Phase "excite".

Sensors (SensorSpec; stated in meta["sensors"])
----------------------------------------------
q: output encoder quantised at encoder_res_deg (0.01° default), sampled exactly.
u: motor-1 encoder (motor_encoder_counts per motor revolution) / N, quantised at 2π/counts/N.
torque: sigma-delta ADC, sinc³ decimation filter (continuous-time kernel = quadratic B-spline of
   support 3·T_w, T_w = 2·lag_s/3, so the group delay is the stated torque_lag_s), then Gaussian
   noise torque_noise.  torque_load: load cell, noise load_cell_noise, no lag.
i_m*, w_m*: currents and motor speeds with Gaussian noise; temp_*: quantised at temp_res_c.
torsion = q − u of the readings.

Unstated imperfections (carried by every run, not in meta; scaled by `unstated_scale`)
-------------------------------------------------------------------------------------
load_dependent_friction: Coulomb grows with |T_el|: + 8e-4·|T_el|·σ  (≈ 96 N·m at 120 kN·m).
temperature_friction: viscous f_v·(1 − 0.006/°C·(T_j − 35 °C))  (+12 % at 15 °C).
gear_ripple: body torque 35 N·m·sin(36·q + 0.4) (a 36-per-revolution bearing/ring line).
(σ = F_BS/f_c: the sliding direction, smooth through reversals.)

Effects (`effects={name: {"form": ..., "scale": s}}`, 0 ≤ s ≤ SCALE_MAX; sizes at s = 1)
----------------------------------------------------------------------------------------
stribeck (F_BS multiplied by 1 + s·(400 N·m/f_c)·g(|q̇|/v_s), v_s = 5e-3 rad/s (17 % of the
   top output speed); +400 N·m at the onset of sliding; at 300 r/min (q̇ ≈ 2.6e-3) 240–310 N·m,
   at 3000 r/min < 30 N·m; the negative slope stays below the output-side damping, so scale 1
   gives no stick–slip):  exponential g = exp(−x);  gaussian g = exp(−x²);
   lorentzian g = 1/(1 + x²);  hyperbolic g = 1/(1 + x).
load_dependent_friction (on the output friction, |T_el| the elastic transmission torque):
   coulomb: + s·0.004·|T_el|·σ  (480 N·m at rated);
   coulomb_viscous: + s·(0.003·|T_el|·σ + (|T_el|/120 kN·m)·f_v·q̇);
   power_flow: + s·(0.004 + 0.002·tanh(T_el·q̇/50 W))·|T_el|·σ  (driving 720, back-driven 240).
temperature_friction (ΔT = T_joint − 35 °C):
   viscous_multiplicative: f_v → f_v·(1 + s·(exp(−0.03·ΔT) − 1));
   coulomb_additive: + s·15 N·m/°C·(−ΔT)·σ;
   both_polynomial: F_BS and f_v·q̇ multiplied by 1 + s·(−0.006·ΔT + 1e-4·ΔT²).
gear_ripple:
   output_harmonics: body torque s·250·Σ_{k=1..3} c_k·sin(k·144·q + φ_k), c = (1, .5, .25),
      φ = (0, .7, 1.9);
   motor_angle_error: transmission angle error Δ → Δ − s·2e-5·sin(2·N·θ_g + 0.3)
      (2 cycles per motor revolution; ≈ 290 N·m of torque ripple);
   load_modulated_mesh: Δ → Δ − s·2e-5·(0.25 + |T_el|/120 kN·m)·sin(144·q).
torque_offset (reading only): constant s·300 N·m; linear_drift s·300·t/60 s;
   warmup s·300·(1 − exp(−t/20 s)).
time_delay (reading only): torque_pure_lag: extra delay s·25 ms on the torque reading;
   torque_filter_lag: first-order low-pass τ = s·25 ms before the ADC;
   encoder_lag: q read s·4 ms late.
hysteresis (torque τ_h added to T; state w driven by the twist rate Δ̇, δ_h = 1.5e-4 rad):
   bouc_wen_n1: ẇ = Δ̇/δ_h·(1 − (0.7·sgn(Δ̇w) + 0.3)·|w|),  τ_h = s·400·w;
   bouc_wen_n3: same with |w|³;
   elastoplastic: ẇ = Δ̇/δ_h·(1 − [w·Δ̇ > 0]·|w|^20), τ_h = s·400·w (parallelogram loop);
   load_proportional: n = 1 state, τ_h = s·0.004·|T_el|·w (480 N·m at rated).
backlash (half gap b = s·3e-5 rad in the transmission twist Δ):
   sharp: Δ → Δ − clip(Δ, −b, b);  smoothed: Δ → Δ − b·tanh(Δ/b);
   soft_gap: Δ → Δ − 0.85·clip(Δ, −b, b)  (15 % stiffness left inside the gap).
asymmetric_friction (added to the output friction):
   coulomb_positive: + s·300·max(σ, 0);  viscous_positive: + s·f_v·max(q̇, 0);
   coulomb_split: + s·200·|σ|;  negative_both: + s·(250·min(σ, 0) + 0.5·f_v·min(q̇, 0)).
Out of vocabulary:
   periodic_disturbance (body torque): sine s·250·sin(2π·1.3 Hz·t);
      pump_pulses s·250·((π/2)·|sin(π·2.1 Hz·t)| − 1).
   position_dependent_stiffness (T_el multiplied): sinusoidal 1 + s·0.01·sin(3q + 1);
      linear 1 + s·0.02·q/rad.
   encoder_drift (reading only, on q): linear s·3e-5 rad/min·t; settling s·5e-5·(1 − exp(−t/30 s)).
   second_resonance (an appendage on the output, J2 = s·0.5·I, q̈2 = ω2²(q − q2) + 2ζω2(q̇ − q̇2),
      reaction −J2·q̈2 on the output): appendage_11hz (ω2 = 2π·11, ζ = 0.02);
      appendage_27hz (ω2 = 2π·27, ζ = 0.005).
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, fields
from datetime import datetime, timedelta, timezone
from typing import Any

import numpy as np
import pandas as pd
from numba import njit

RIG_NAME = "rig_x"
REDUCTION = 11000.0
SEED_IS_CAMPAIGN = True
SCALE_MAX = 10.0

EFFECT_FORMS: dict[str, tuple[str, ...]] = {
    "stribeck": ("exponential", "gaussian", "lorentzian", "hyperbolic"),
    "load_dependent_friction": ("coulomb", "coulomb_viscous", "power_flow"),
    "temperature_friction": ("viscous_multiplicative", "coulomb_additive", "both_polynomial"),
    "gear_ripple": ("output_harmonics", "motor_angle_error", "load_modulated_mesh"),
    "torque_offset": ("constant", "linear_drift", "warmup"),
    "time_delay": ("torque_pure_lag", "torque_filter_lag", "encoder_lag"),
    "hysteresis": ("bouc_wen_n1", "bouc_wen_n3", "elastoplastic", "load_proportional"),
    "backlash": ("sharp", "smoothed", "soft_gap"),
    "asymmetric_friction": ("coulomb_positive", "viscous_positive", "coulomb_split",
                            "negative_both"),
    "periodic_disturbance": ("sine", "pump_pulses"),
    "position_dependent_stiffness": ("sinusoidal", "linear"),
    "encoder_drift": ("linear", "settling"),
    "second_resonance": ("appendage_11hz", "appendage_27hz"),
}
OUT_OF_VOCABULARY: tuple[str, ...] = ("periodic_disturbance", "position_dependent_stiffness",
                                      "encoder_drift", "second_resonance")
UNSTATED_VOCABULARY: dict[str, str] = {
    "load_dependent_friction": "Coulomb friction grows by 8e-4·|transmitted torque| "
                               "(≈ 96 N·m at 120 kN·m)",
    "temperature_friction": "viscous friction f_v·(1 − 0.006/°C·(T_joint − 35 °C))",
    "gear_ripple": "output body torque 35 N·m·sin(36·q + 0.4)",
}
SENSOR_ONLY_EFFECTS = ("torque_offset", "time_delay", "encoder_drift")

RATED_TORQUE = 120e3
PERIOD_S = 20.0
H_MAX = 5e-4

# --- parameter vector layout (the numba kernel reads P by these indices) ----------------------
P_I, P_MRX, P_MRY, P_FV, P_FC, P_G = 0, 1, 2, 3, 4, 5
P_JM, P_BM, P_KP, P_CP, P_JG = 6, 7, 8, 9, 10
P_K0, P_DS, P_DT = 11, 12, 13
P_BSETA, P_BSEPS, P_BSF1, P_BSF2 = 14, 15, 16, 17
P_JL, P_KL, P_CL, P_BL, P_TLM, P_KPL, P_KIL = 18, 19, 20, 21, 22, 23, 24
P_KPS, P_KIS, P_TI, P_MIS2, P_MIS3, P_DROOP = 25, 26, 27, 28, 29, 30
P_UMU, P_ULAM, P_UTREF, P_URIP, P_UZ = 31, 32, 33, 34, 35
P_KT, P_RW, P_CM, P_RM, P_CJ, P_RJ, P_RMJ, P_TAMB, P_ETAL = 36, 37, 38, 39, 40, 41, 42, 43, 44
P_N, P_SCHEME, P_DIR, P_WT, P_TRAMP, P_WF, P_JTOT = 45, 46, 47, 48, 49, 50, 51
NP = 52

# physical effect families in the kernel (form code 0 = off)
F_STRIB, F_LDF, F_TEMP, F_RIP, F_HYST, F_BACK, F_ASYM, F_PDIST, F_PSTIFF, F_RES2 = range(10)
NF = 10
_FAMILY_INDEX = {"stribeck": F_STRIB, "load_dependent_friction": F_LDF,
                 "temperature_friction": F_TEMP, "gear_ripple": F_RIP, "hysteresis": F_HYST,
                 "backlash": F_BACK, "asymmetric_friction": F_ASYM,
                 "periodic_disturbance": F_PDIST, "position_dependent_stiffness": F_PSTIFF,
                 "second_resonance": F_RES2}

NY = 23      # state size
NAUX = 16    # aux outputs
# aux layout
A_T, A_TL, A_TEL, A_FF, A_M1, A_M2, A_M3, A_TCMD, A_WREF, A_TWIST, A_PLOSS, A_QDD, A_TBODY = \
    0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12

_GAM = 1.0 - 1.0 / math.sqrt(2.0)

# effect sizes at scale 1 (used inside the kernel; module constants are frozen by numba)
STRIB_DF, STRIB_VS = 400.0, 5e-3
LDF_MU, LDF_MU2 = 0.004, 0.003
TEMP_LAM, TEMP_CT, TEMP_K1, TEMP_K2, TEMP_REF = 0.03, 15.0, 0.006, 1e-4, 35.0
RIP_A, RIP_Z, RIP_EM, RIP_EO = 250.0, 144.0, 2e-5, 2e-5
HYS_H, HYS_DH, HYS_MU = 400.0, 1.5e-4, 0.004
BACK_B, BACK_RHO = 3e-5, 0.15
ASYM_C1, ASYM_C3, ASYM_C4 = 300.0, 200.0, 250.0
PD_A, PD_F1, PD_F2 = 250.0, 1.3, 2.1
PS_A1, PS_A2 = 0.01, 0.02
RES_JFRAC = 0.5
OFFSET_A = 300.0
DELAY_TORQUE, DELAY_ENC = 0.025, 0.004
DRIFT_RATE, DRIFT_SETTLE = 3e-5 / 60.0, 5e-5

FOURIER_A = np.array([1.0, -0.6, 0.5, -0.5, -0.4])
FOURIER_B = np.array([0.8, 0.3, -0.2, -0.25, 0.04])


def _fourier_unit() -> tuple[np.ndarray, np.ndarray]:
    """Eq. 12 speed coefficients scaled so the peak output speed is 1 rad/s (then scaled)."""
    wf = 2 * math.pi / PERIOD_S
    tt = np.linspace(0.0, PERIOD_S, 20001)
    v = sum(FOURIER_A[l] * np.cos(wf * (l + 1) * tt) + FOURIER_B[l] * np.sin(wf * (l + 1) * tt)
            for l in range(5))
    peak = float(np.max(np.abs(v)))
    return FOURIER_A / peak, FOURIER_B / peak


# --- the kernel --------------------------------------------------------------------------------

@njit(cache=True)
def _interp1(t, tb, vb):
    n = tb.shape[0]
    if t <= tb[0]:
        return vb[0]
    if t >= tb[n - 1]:
        return vb[n - 1]
    lo = 0
    hi = n - 1
    while hi - lo > 1:
        mid = (lo + hi) // 2
        if tb[mid] <= t:
            lo = mid
        else:
            hi = mid
    r = (t - tb[lo]) / (tb[hi] - tb[lo])
    return vb[lo] + r * (vb[hi] - vb[lo])


@njit(cache=True)
def _rhs(t, y, P, E, S, tb, vb, fa, fb, Tj, dy, aux):
    N = P[P_N]
    d = P[P_DIR]
    # --- schedule: speed reference of motor 1 and the load set point
    if P[P_SCHEME] < 2.5:
        r = t / P[P_TRAMP]
        if r >= 1.0:
            sm = 1.0
            dsm = 0.0
        else:
            sm = r * r * (3.0 - 2.0 * r)
            dsm = 6.0 * r * (1.0 - r) / P[P_TRAMP]
        wref = d * P[P_WT] * sm
        aref = d * P[P_WT] * dsm
        tcmd = _interp1(t, tb, vb)
    else:
        wf = P[P_WF]
        wref = 0.0
        aref = 0.0
        for l in range(5):
            wl = wf * (l + 1)
            c = math.cos(wl * t)
            s = math.sin(wl * t)
            wref += fa[l] * c + fb[l] * s
            aref += -fa[l] * wl * s + fb[l] * wl * c
        wref *= d
        aref *= d
        tcmd = 0.0
    # --- states
    w1 = y[3]
    Dl = y[6]
    wg = y[7]
    q = y[8]
    v = y[9]
    x1 = y[10]
    x2 = y[11]
    wh = y[12]
    dL = y[13]
    vL = y[14]
    ML = y[15]
    IL = y[16]
    Is = y[17]
    # --- speed loop (motor 1) and current loops; slaves follow motor 1's command
    e = wref - w1
    Mc = P[P_KPS] * e + Is + P[P_JTOT] * aref
    dy[17] = P[P_KIS] * e
    spsum = 0.0
    for j in range(3):
        if j == 0:
            cj = Mc
        elif j == 1:
            cj = Mc * (1.0 + P[P_MIS2]) - P[P_DROOP] * (y[4] - w1)
        else:
            cj = Mc * (1.0 + P[P_MIS3]) - P[P_DROOP] * (y[5] - w1)
        Mj = y[18 + j]
        dy[18 + j] = (cj - Mj) / P[P_TI]
        pj = P[P_KP] * y[j] + P[P_CP] * (y[3 + j] - wg)
        spsum += pj
        dy[j] = y[3 + j] - wg
        dy[3 + j] = (Mj - pj - P[P_BM] * y[3 + j]) / P[P_JM]
        aux[A_M1 + j] = Mj
    # --- transmission
    Dd = wg - v
    De = Dl
    fb_ = E[F_BACK]
    if fb_ != 0:
        b = S[F_BACK] * BACK_B
        if fb_ == 1:
            De = Dl - min(max(Dl, -b), b)
        elif fb_ == 2:
            De = Dl - b * math.tanh(Dl / b)
        else:
            De = Dl - (1.0 - BACK_RHO) * min(max(Dl, -b), b)
    # elastic torque before transmission-error terms (for load-modulated terms)
    Tel0 = P[P_K0] * Dl / (1.0 + abs(Dl) / P[P_DS])
    fr = E[F_RIP]
    if fr == 2:
        De -= S[F_RIP] * RIP_EM * math.sin(2.0 * N * (q + Dl) + 0.3)
    elif fr == 3:
        De -= S[F_RIP] * RIP_EO * (0.25 + abs(Tel0) / RATED_TORQUE) * math.sin(RIP_Z * q)
    Tel = P[P_K0] * De / (1.0 + abs(De) / P[P_DS])
    fp = E[F_PSTIFF]
    if fp == 1:
        Tel *= 1.0 + S[F_PSTIFF] * PS_A1 * math.sin(3.0 * q + 1.0)
    elif fp == 2:
        Tel *= 1.0 + S[F_PSTIFF] * PS_A2 * q
    # hysteresis
    fh = E[F_HYST]
    tauh = 0.0
    if fh != 0:
        aw = abs(wh)
        sg = 1.0 if Dd * wh > 0 else (-1.0 if Dd * wh < 0 else 0.0)
        if fh == 1 or fh == 4:
            dy[12] = Dd / HYS_DH * (1.0 - (0.7 * sg + 0.3) * aw)
        elif fh == 2:
            dy[12] = Dd / HYS_DH * (1.0 - (0.7 * sg + 0.3) * aw * aw * aw)
        else:
            on = 1.0 if Dd * wh > 0 else 0.0
            a2 = aw * aw
            a4 = a2 * a2
            a5 = a4 * aw
            a20 = a5 * a5 * a5 * a5
            dy[12] = Dd / HYS_DH * (1.0 - on * a20)
        if fh == 4:
            tauh = S[F_HYST] * HYS_MU * abs(Tel) * wh
        else:
            tauh = S[F_HYST] * HYS_H * wh
    else:
        dy[12] = 0.0
    T = Tel + P[P_DT] * Dd + tauh
    dy[6] = Dd
    dy[7] = (spsum - T) / P[P_JG]
    # --- output friction: Bliman–Sorine + viscous + effects
    av = abs(v)
    ie = 1.0 / (P[P_BSETA] * P[P_BSEPS])
    dy[10] = (v * P[P_BSF1] - av * x1) * ie
    dy[11] = (-v * P[P_BSF2] - av * x2) / P[P_BSEPS]
    FBS = x1 + x2
    fc = P[P_FC]
    sig = FBS / fc
    fv = P[P_FV]
    dT = Tj - TEMP_REF
    cmult = 1.0
    vmult = 1.0
    fadd = 0.0
    # unstated imperfections
    vmult -= P[P_ULAM] * (Tj - P[P_UTREF])
    fadd += P[P_UMU] * abs(Tel) * sig
    tbody = P[P_URIP] * math.sin(P[P_UZ] * q + 0.4)
    fs = E[F_STRIB]
    if fs != 0:
        x = av / STRIB_VS
        if fs == 1:
            g = math.exp(-x)
        elif fs == 2:
            g = math.exp(-x * x)
        elif fs == 3:
            g = 1.0 / (1.0 + x * x)
        else:
            g = 1.0 / (1.0 + x)
        cmult += S[F_STRIB] * STRIB_DF / fc * g
    fl = E[F_LDF]
    if fl == 1:
        fadd += S[F_LDF] * LDF_MU * abs(Tel) * sig
    elif fl == 2:
        fadd += S[F_LDF] * (LDF_MU2 * abs(Tel) * sig + abs(Tel) / RATED_TORQUE * fv * v)
    elif fl == 3:
        mu = 0.004 + 0.002 * math.tanh(Tel * v / 50.0)
        fadd += S[F_LDF] * mu * abs(Tel) * sig
    ft = E[F_TEMP]
    if ft == 1:
        vmult += S[F_TEMP] * (math.exp(-TEMP_LAM * dT) - 1.0)
    elif ft == 2:
        fadd += S[F_TEMP] * TEMP_CT * (-dT) * sig
    elif ft == 3:
        m = S[F_TEMP] * (-TEMP_K1 * dT + TEMP_K2 * dT * dT)
        cmult += m
        vmult += m
    fa_ = E[F_ASYM]
    if fa_ == 1:
        fadd += S[F_ASYM] * ASYM_C1 * max(sig, 0.0)
    elif fa_ == 2:
        fadd += S[F_ASYM] * fv * max(v, 0.0)
    elif fa_ == 3:
        fadd += S[F_ASYM] * ASYM_C3 * abs(sig)
    elif fa_ == 4:
        fadd += S[F_ASYM] * (ASYM_C4 * min(sig, 0.0) + 0.5 * fv * min(v, 0.0))
    Ff = FBS * cmult + fv * vmult * v + fadd
    # --- body torques: ripple, disturbances, appendage
    if fr == 1:
        tbody += S[F_RIP] * RIP_A * (math.sin(RIP_Z * q) + 0.5 * math.sin(2.0 * RIP_Z * q + 0.7)
                                     + 0.25 * math.sin(3.0 * RIP_Z * q + 1.9))
    fd = E[F_PDIST]
    if fd == 1:
        tbody += S[F_PDIST] * PD_A * math.sin(2.0 * math.pi * PD_F1 * t)
    elif fd == 2:
        tbody += S[F_PDIST] * PD_A * (0.5 * math.pi * abs(math.sin(math.pi * PD_F2 * t)) - 1.0)
    f2 = E[F_RES2]
    if f2 != 0:
        if f2 == 1:
            w2 = 2.0 * math.pi * 11.0
            z2 = 0.02
        else:
            w2 = 2.0 * math.pi * 27.0
            z2 = 0.005
        # y[21] = q2 − q, y[22] = q̇2
        a2 = -w2 * w2 * y[21] + 2.0 * z2 * w2 * (v - y[22])
        tbody += S[F_RES2] * RES_JFRAC * P[P_I] * a2
        dy[22] = a2
    else:
        dy[22] = 0.0
    dy[21] = y[22] - v if f2 != 0 else 0.0
    # --- loader
    tauL = P[P_KL] * dL + P[P_CL] * (v - vL)
    eL = tcmd - tauL
    dy[13] = v - vL
    dy[14] = (tauL - ML - P[P_BL] * vL) / P[P_JL]
    dy[15] = (tcmd + P[P_KPL] * eL + IL - ML) / P[P_TLM]
    dy[16] = P[P_KIL] * eL
    # --- output body
    G = P[P_G] * (P[P_MRX] * math.sin(q) + P[P_MRY] * math.cos(q))
    qdd = (T - tauL - G - Ff - tbody) / P[P_I]
    dy[8] = v
    dy[9] = qdd
    aux[A_T] = T
    aux[A_TL] = tauL
    aux[A_TEL] = Tel
    aux[A_FF] = Ff
    aux[A_TCMD] = tcmd
    aux[A_WREF] = wref
    aux[A_TWIST] = y[0] + Dl
    aux[A_PLOSS] = abs(Ff * v) + P[P_ETAL] * abs(Tel * wg)
    aux[A_QDD] = qdd
    aux[A_TBODY] = tbody


@njit(cache=True)
def _lu(A, piv):
    n = A.shape[0]
    for k in range(n):
        p = k
        amax = abs(A[k, k])
        for i in range(k + 1, n):
            if abs(A[i, k]) > amax:
                amax = abs(A[i, k])
                p = i
        piv[k] = p
        if p != k:
            for j in range(n):
                tmp = A[k, j]
                A[k, j] = A[p, j]
                A[p, j] = tmp
        akk = A[k, k]
        if akk == 0.0:
            return False
        for i in range(k + 1, n):
            A[i, k] /= akk
            lik = A[i, k]
            if lik != 0.0:
                for j in range(k + 1, n):
                    A[i, j] -= lik * A[k, j]
    return True


@njit(cache=True)
def _lusolve(A, piv, b):
    n = A.shape[0]
    for k in range(n):
        p = piv[k]
        if p != k:
            tmp = b[k]
            b[k] = b[p]
            b[p] = tmp
    for i in range(n):
        s = b[i]
        for j in range(i):
            s -= A[i, j] * b[j]
        b[i] = s
    for i in range(n - 1, -1, -1):
        s = b[i]
        for j in range(i + 1, n):
            s -= A[i, j] * b[j]
        b[i] = s / A[i, i]


@njit(cache=True)
def _jacobian(t, y, P, E, S, tb, vb, fa, fb, Tj, J, f0, f1, yp, aux, typ):
    n = y.shape[0]
    _rhs(t, y, P, E, S, tb, vb, fa, fb, Tj, f0, aux)
    for i in range(n):
        yp[:] = y
        dlt = 1e-8 * max(abs(y[i]), typ[i])
        yp[i] += dlt
        _rhs(t, yp, P, E, S, tb, vb, fa, fb, Tj, f1, aux)
        for k in range(n):
            J[k, i] = (f1[k] - f0[k]) / dlt


@njit(cache=True)
def _newton(t, base, Y, hg, P, E, S, tb, vb, fa, fb, Tj, M, piv, F, r, aux, atol):
    """Solve Y = base + hg·f(t, Y) by modified Newton; returns iterations (−1 on failure)."""
    n = Y.shape[0]
    prev = 1e300
    for it in range(12):
        _rhs(t, Y, P, E, S, tb, vb, fa, fb, Tj, F, aux)
        for k in range(n):
            r[k] = -(Y[k] - base[k] - hg * F[k])
        _lusolve(M, piv, r)
        err = 0.0
        for k in range(n):
            Y[k] += r[k]
            ek = abs(r[k]) / (atol[k] + 1e-8 * abs(Y[k]))
            if ek > err:
                err = ek
        if not (err < 1e30):
            return -1
        if err < 1.0:
            return it + 1
        if it >= 2 and err > 0.9 * prev:
            return -1
        prev = err
    return -1


@njit(cache=True)
def _simulate(y0, P, E, S, tb, vb, fa, fb, n_samples, n_sub, h, temps0, atol, typ):
    n = y0.shape[0]
    n_fine = (n_samples - 1) * n_sub + 1
    fine = np.empty((n_fine, 5))   # t, T, tauL, q, twist
    ys = np.empty((n_samples, n))
    auxs = np.empty((n_samples, NAUX))
    temps = np.empty((n_samples, 4))  # joint, m1, m2, m3
    y = y0.copy()
    aux = np.zeros(NAUX)
    dy = np.zeros(n)
    J = np.zeros((n, n))
    M = np.zeros((n, n))
    piv = np.zeros(n, dtype=np.int64)
    f0 = np.zeros(n)
    f1 = np.zeros(n)
    yp = np.zeros(n)
    F = np.zeros(n)
    r = np.zeros(n)
    Y1 = np.zeros(n)
    Y2 = np.zeros(n)
    base = np.zeros(n)
    ysave = np.zeros(n)
    Tj = temps0[0]
    Tm = temps0[1:4].copy()
    jage = 1000
    hM = -1.0
    nfail = 0
    njac = 0
    t = 0.0
    _rhs(t, y, P, E, S, tb, vb, fa, fb, Tj, dy, aux)
    ys[0, :] = y
    auxs[0, :] = aux
    temps[0, 0] = Tj
    temps[0, 1:4] = Tm
    fine[0, 0] = 0.0
    fine[0, 1] = aux[A_T]
    fine[0, 2] = aux[A_TL]
    fine[0, 3] = y[8]
    fine[0, 4] = aux[A_TWIST]
    ifine = 0
    dts = h * n_sub
    for k in range(n_samples - 1):
        for s in range(n_sub):
            t0 = (k * n_sub + s) * h
            ysave[:] = y
            done = False
            m = 1
            while not done:
                y[:] = ysave
                hh = h / m
                ok = True
                for i in range(m):
                    tt = t0 + i * hh
                    stepped = False
                    for attempt in range(2):
                        if jage >= 8 or attempt == 1:
                            _jacobian(tt, y, P, E, S, tb, vb, fa, fb, Tj, J, f0, f1, yp, aux,
                                      typ)
                            njac += 1
                            jage = 0
                            hM = -1.0
                        if hM != hh:
                            for a in range(n):
                                for b in range(n):
                                    M[a, b] = -hh * _GAM * J[a, b]
                                M[a, a] += 1.0
                            _lu(M, piv)
                            hM = hh
                        # stage 1
                        base[:] = y
                        Y1[:] = y
                        it1 = _newton(tt + _GAM * hh, base, Y1, hh * _GAM, P, E, S, tb, vb, fa,
                                      fb, Tj, M, piv, F, r, aux, atol)
                        if it1 < 0:
                            jage = 1000
                            continue
                        # stage 2
                        for a in range(n):
                            k1 = (Y1[a] - y[a]) / (hh * _GAM)
                            base[a] = y[a] + hh * (1.0 - _GAM) * k1
                            Y2[a] = y[a] + hh * k1
                        it2 = _newton(tt + hh, base, Y2, hh * _GAM, P, E, S, tb, vb, fa, fb,
                                      Tj, M, piv, F, r, aux, atol)
                        if it2 < 0:
                            jage = 1000
                            continue
                        y[:] = Y2
                        jage += 1
                        if it1 > 4 or it2 > 4:
                            jage = 1000
                        stepped = True
                        break
                    if not stepped:
                        ok = False
                        break
                if ok:
                    done = True
                else:
                    nfail += 1
                    jage = 1000
                    m *= 2
                    if m > 64:
                        y[:] = ysave
                        return fine, ys, auxs, temps, -1, njac
            ifine += 1
            _rhs(t0 + h, y, P, E, S, tb, vb, fa, fb, Tj, dy, aux)
            fine[ifine, 0] = t0 + h
            fine[ifine, 1] = aux[A_T]
            fine[ifine, 2] = aux[A_TL]
            fine[ifine, 3] = y[8]
            fine[ifine, 4] = aux[A_TWIST]
        # sample k+1 (the state exactly at the sample instant)
        t = (k + 1) * dts
        _rhs(t, y, P, E, S, tb, vb, fa, fb, Tj, dy, aux)
        ys[k + 1, :] = y
        auxs[k + 1, :] = aux
        # thermal (explicit, time constants ~1e3 s)
        N = P[P_N]
        pj = aux[A_PLOSS]
        for j in range(3):
            i_a = aux[A_M1 + j] / (N * P[P_KT])
            qin = P[P_RW] * i_a * i_a - (Tm[j] - P[P_TAMB]) / P[P_RM] - (Tm[j] - Tj) / P[P_RMJ]
            pj += (Tm[j] - Tj) / P[P_RMJ]
            Tm[j] += dts * qin / P[P_CM]
        Tj += dts * (pj - (Tj - P[P_TAMB]) / P[P_RJ]) / P[P_CJ]
        temps[k + 1, 0] = Tj
        temps[k + 1, 1:4] = Tm
    return fine, ys, auxs, temps, nfail, njac


# --- sensors -----------------------------------------------------------------------------------

def _check_number(name: str, v: Any, lo: float, hi: float, *, lo_open: bool = False) -> float:
    if isinstance(v, (bool, np.bool_)) or not isinstance(v, (int, float, np.integer, np.floating)):
        raise ValueError(f"{name} must be a number, got {v!r}")
    x = float(v)
    if not math.isfinite(x):
        raise ValueError(f"{name} must be finite, got {v!r}")
    if x < lo or x > hi or (lo_open and x <= lo):
        raise ValueError(f"{name} must be in {'(' if lo_open else '['}{lo}, {hi}], got {v!r}")
    return x


@dataclass
class SensorSpec:
    """What the bench's sensors are (a data sheet). Every field is range-checked."""
    sample_rate_hz: float = 100.0          # 10..1000
    encoder_res_deg: float = 0.01          # output encoder step, 1e-6..1 deg
    torque_noise: float = 150.0            # N·m sd of the transmitted-torque reading
    torque_lag_s: float = 0.002            # group delay of the sinc³ ADC filter, s
    motor_encoder_counts: float = 1048576.0  # counts per motor revolution
    load_cell_noise: float = 100.0         # N·m sd
    current_noise: float = 0.01            # A sd
    speed_noise: float = 0.2               # rad/s sd (motor side)
    temp_res_c: float = 0.1                # temperature quantisation, °C

    _RANGES = {"sample_rate_hz": (10.0, 1000.0), "encoder_res_deg": (1e-6, 1.0),
               "torque_noise": (0.0, 5000.0), "torque_lag_s": (0.0, 0.05),
               "motor_encoder_counts": (1024.0, 2.0 ** 28), "load_cell_noise": (0.0, 5000.0),
               "current_noise": (0.0, 1.0), "speed_noise": (0.0, 10.0),
               "temp_res_c": (0.0, 1.0)}

    def __post_init__(self) -> None:
        for f in fields(self):
            lo, hi = self._RANGES[f.name]
            setattr(self, f.name, _check_number(f.name, getattr(self, f.name), lo, hi))

    def key(self) -> tuple:
        return tuple(getattr(self, f.name) for f in fields(self))


@dataclass
class RigRun:
    samples: pd.DataFrame
    meta: dict
    truth: pd.DataFrame
    params: dict


# --- machine, schedule ------------------------------------------------------------------------

def _machine(seed: int) -> dict[str, float]:
    rng = np.random.default_rng([int(seed), 0x4A34])
    z = rng.standard_normal(12)
    m = {
        "I": 6685.166 * (1 + 0.01 * z[0] / 2),
        "mr_x": 20.779 * (1 + 0.02 * z[1] / 2),
        "mr_y": -34.543 * (1 + 0.02 * z[2] / 2),
        "f_v": 8683.272 * (1 + 0.01 * z[3] / 2),
        "f_c": 2352.660 * (1 + 0.01 * z[4] / 2),
        "g": 9.81,
        "k0": 1.471e7 * (1 + 0.03 * z[5] / 2),
        "delta_s": 0.1247,
        "D": 1.2e5,
        "bs_eta": 0.15,
        "bs_eps": 5e-5 * (1 + 0.05 * z[6] / 2),
        "J_m_ref": 6e-4 * REDUCTION ** 2,
        "b_m_ref": 2e3,
        "k_p": 4e8 * (1 + 0.05 * z[7] / 2),
        "c_p": 6e5,
        "J_g": 3e4,
        "J_L": 1.5e4,
        "k_L": 2.5e7,
        "c_L": 1e5,
        "b_L": 3e3,
        "tau_loadmotor": 5e-3,
        "kp_loader": 0.3,
        "ki_loader": 3.0,
        "kp_speed": 3.7e6,
        "ki_speed": 1.1e7,
        "tau_current": 1e-3,
        "mismatch_2": 0.02 * float(np.clip(z[8], -1.5, 1.5)) / 1.5,
        "mismatch_3": 0.02 * float(np.clip(z[9], -1.5, 1.5)) / 1.5,
        "droop": 2e5,
        "k_t": 1.2,
        "R_winding": 1.2,
        "C_motor": 2000.0,
        "R_motor_amb": 0.5,
        "C_joint": 2e4,
        "R_joint_amb": 0.05,
        "R_motor_joint": 4.0,
        "T_ambient": 22.0,
        "gear_loss_fraction": 0.03,
    }
    m["bs_f1"] = 1.35 * m["f_c"]
    m["bs_f2"] = 0.35 * m["f_c"]
    return m


UNSTATED_VALUES = {"load_dependent_friction": {"mu": 8e-4},
                   "temperature_friction": {"lambda_per_c": 0.006, "t_ref_c": 35.0},
                   "gear_ripple": {"amplitude_nm": 35.0, "cycles_per_rev": 36.0, "phase": 0.4}}


def _schedule(scheme: int, periods: int) -> tuple[float, np.ndarray, np.ndarray, list]:
    """(duration, load breakpoints t, values, phase intervals [(t0, t1, name)])."""
    if scheme == 1:
        tb = np.array([0.0, 5.0, 35.0, 65.0, 70.0])
        vb = np.array([0.0, 0.0, RATED_TORQUE, 0.0, 0.0])
        ph = [(0.0, 5.0, "idle"), (5.0, 35.0, "load"), (35.0, 65.0, "unload"),
              (65.0, 70.0, "idle")]
        return 70.0, tb, vb, ph
    if scheme == 2:
        tl, vl, ph = [0.0, 2.0], [0.0, 0.0], [(0.0, 2.0, "idle")]
        t, v = 2.0, 0.0
        for _ in range(12):
            ph.append((t, t + 1.0, "load"))
            t += 1.0
            v += 10e3
            tl.append(t)
            vl.append(v)
            ph.append((t, t + 2.0, "hold"))
            t += 2.0
            tl.append(t)
            vl.append(v)
        for _ in range(12):
            ph.append((t, t + 1.0, "unload"))
            t += 1.0
            v -= 10e3
            tl.append(t)
            vl.append(v)
            ph.append((t, t + 1.0, "hold"))
            t += 1.0
            tl.append(t)
            vl.append(v)
        ph.append((t, t + 2.0, "idle"))
        t += 2.0
        tl.append(t)
        vl.append(0.0)
        return t, np.array(tl), np.array(vl), ph
    dur = PERIOD_S * periods
    return dur, np.array([0.0, dur]), np.array([0.0, 0.0]), [(0.0, dur, "excite")]


def _validate_int(name: str, v: Any, allowed: tuple | None = None, lo: int | None = None,
                  hi: int | None = None) -> int:
    if isinstance(v, (bool, np.bool_)) or not isinstance(v, (int, np.integer)):
        if isinstance(v, (float, np.floating)) and math.isfinite(v) and float(v).is_integer():
            v = int(v)
        else:
            raise ValueError(f"{name} must be an integer, got {v!r}")
    v = int(v)
    if allowed is not None and v not in allowed:
        raise ValueError(f"{name} must be one of {allowed}, got {v!r}")
    if lo is not None and v < lo:
        raise ValueError(f"{name} must be >= {lo}, got {v!r}")
    if hi is not None and v > hi:
        raise ValueError(f"{name} must be <= {hi}, got {v!r}")
    return v


def _validate_effects(effects: Any) -> dict[str, dict]:
    if effects is None:
        return {}
    if not isinstance(effects, dict):
        raise ValueError(f"effects must be a dict {{name: {{'form', 'scale'}}}}, got {effects!r}")
    out = {}
    for name, spec in effects.items():
        if name not in EFFECT_FORMS:
            raise ValueError(f"effects: unknown effect {name!r}; known: {sorted(EFFECT_FORMS)}")
        if not isinstance(spec, dict) or set(spec) != {"form", "scale"}:
            raise ValueError(f"effects[{name!r}] must be {{'form': str, 'scale': float}}, "
                             f"got {spec!r}")
        form = spec["form"]
        if form not in EFFECT_FORMS[name]:
            raise ValueError(f"effects[{name!r}] form {form!r} unknown; forms: "
                             f"{EFFECT_FORMS[name]}")
        scale = _check_number(f"effects[{name!r}] scale", spec["scale"], 0.0, SCALE_MAX)
        out[name] = {"form": form, "scale": scale}
    return out


def _param_vector(m: dict, scheme: int, direction: int, rpm: float | None,
                  unstated_scale: float) -> np.ndarray:
    P = np.zeros(NP)
    P[P_I], P[P_MRX], P[P_MRY], P[P_FV], P[P_FC], P[P_G] = (m["I"], m["mr_x"], m["mr_y"],
                                                            m["f_v"], m["f_c"], m["g"])
    P[P_JM], P[P_BM], P[P_KP], P[P_CP], P[P_JG] = m["J_m_ref"], m["b_m_ref"], m["k_p"], \
        m["c_p"], m["J_g"]
    P[P_K0], P[P_DS], P[P_DT] = m["k0"], m["delta_s"], m["D"]
    P[P_BSETA], P[P_BSEPS], P[P_BSF1], P[P_BSF2] = m["bs_eta"], m["bs_eps"], m["bs_f1"], \
        m["bs_f2"]
    P[P_JL], P[P_KL], P[P_CL], P[P_BL] = m["J_L"], m["k_L"], m["c_L"], m["b_L"]
    P[P_TLM], P[P_KPL], P[P_KIL] = m["tau_loadmotor"], m["kp_loader"], m["ki_loader"]
    P[P_KPS], P[P_KIS], P[P_TI] = m["kp_speed"], m["ki_speed"], m["tau_current"]
    P[P_MIS2], P[P_MIS3], P[P_DROOP] = m["mismatch_2"], m["mismatch_3"], m["droop"]
    u = UNSTATED_VALUES
    P[P_UMU] = unstated_scale * u["load_dependent_friction"]["mu"]
    P[P_ULAM] = unstated_scale * u["temperature_friction"]["lambda_per_c"]
    P[P_UTREF] = u["temperature_friction"]["t_ref_c"]
    P[P_URIP] = unstated_scale * u["gear_ripple"]["amplitude_nm"]
    P[P_UZ] = u["gear_ripple"]["cycles_per_rev"]
    P[P_KT], P[P_RW], P[P_CM], P[P_RM] = m["k_t"], m["R_winding"], m["C_motor"], m["R_motor_amb"]
    P[P_CJ], P[P_RJ], P[P_RMJ], P[P_TAMB] = m["C_joint"], m["R_joint_amb"], m["R_motor_joint"], \
        m["T_ambient"]
    P[P_ETAL] = m["gear_loss_fraction"]
    P[P_N] = REDUCTION
    P[P_SCHEME] = scheme
    P[P_DIR] = direction
    P[P_WT] = 0.0 if rpm is None else rpm * 2 * math.pi / 60.0 / REDUCTION
    P[P_TRAMP] = 1.0
    P[P_WF] = 2 * math.pi / PERIOD_S
    P[P_JTOT] = 3 * m["J_m_ref"] + m["J_g"]
    return P


def _initial_state(P: np.ndarray) -> np.ndarray:
    """Static equilibrium at rest at q = 0 with no load: the transmission holds gravity."""
    y = np.zeros(NY)
    G = P[P_G] * P[P_MRY]  # gravity torque at q = 0
    # T_el(Δ) = G  →  Δ = G / (k0 − |G|/Δs)
    D = G / (P[P_K0] - abs(G) / P[P_DS])
    mc = G / (3.0 + P[P_MIS2] + P[P_MIS3])
    shares = [mc, mc * (1 + P[P_MIS2]), mc * (1 + P[P_MIS3])]
    for j in range(3):
        y[j] = shares[j] / P[P_KP]
        y[18 + j] = shares[j]
    y[6] = D
    y[17] = mc
    return y


_ATOL = np.array([1e-13] * 3 + [1e-11] * 3 + [1e-12, 1e-11, 1e-11, 1e-11, 1e-3, 1e-3, 1e-8,
                                              1e-12, 1e-11, 1e-3, 1e-3, 1e-3, 1e-3, 1e-3,
                                              1e-3, 1e-12, 1e-11])
_TYP = np.array([1e-5] * 3 + [1e-3] * 3 + [1e-3, 1e-3, 1e-2, 1e-3, 1e2, 1e2, 1e-2,
                                           1e-4, 1e-3, 1e3, 1e3, 1e3, 1e3, 1e3, 1e3, 1e-6, 1e-4])


def _bspline3(x: np.ndarray) -> np.ndarray:
    """Quadratic B-spline on [−1.5, 1.5] (= three unit boxcars convolved), peak 0.75."""
    a = np.abs(x)
    return np.where(a < 0.5, 0.75 - a * a, np.where(a < 1.5, 0.5 * (1.5 - a) ** 2, 0.0))


def _sinc3_read(t_s: np.ndarray, tf: np.ndarray, xf: np.ndarray, lag: float, h: float
                ) -> np.ndarray:
    """Sigma-delta sinc³ reading of a fine-grid signal: the continuous sinc³ kernel (support
    3·T_w, T_w = 2·lag/3) centred at the group delay `lag`, sampled on the inner grid."""
    tw = 2.0 * lag / 3.0
    if tw < 1e-12:
        return np.interp(t_s, tf, xf)
    K = int(math.floor(1.5 * tw / h))
    j = np.arange(-K, K + 1)
    w = _bspline3(j * h / tw)
    if w.sum() <= 0:
        return np.interp(t_s - lag, tf, xf)
    w = w / w.sum()
    out = np.zeros_like(t_s)
    for jj, wj in zip(j, w):
        out += wj * np.interp(t_s - lag + jj * h, tf, xf)
    return out


def _first_order(tf: np.ndarray, xf: np.ndarray, tau: float) -> np.ndarray:
    if tau <= 0:
        return xf
    h = tf[1] - tf[0]
    a = math.exp(-h / tau)
    from scipy.signal import lfilter
    y, _ = lfilter([1 - a], [1, -a], xf, zi=[a * xf[0]])
    return y


# --- the entry point ---------------------------------------------------------------------------

def simulate_run(scheme: int, motor_speed_rpm: float | None, direction: int,
                 temp_joint_c: float, effects: dict[str, dict] | None = None, *,
                 sensors: SensorSpec | None = None, periods: int = 3, seed: int, run: int,
                 unstated_scale: float = 1.0) -> RigRun:
    """Simulate one run of the bench. `unstated_scale` (0..SCALE_MAX, default 1) scales the
    bench's unstated imperfections (0 = the nominal machine)."""
    scheme = _validate_int("scheme", scheme, allowed=(1, 2, 3))
    if scheme in (1, 2):
        if motor_speed_rpm is None:
            raise ValueError("motor_speed_rpm is required for schemes 1 and 2")
        rpm = _check_number("motor_speed_rpm", motor_speed_rpm, 0.0, 3000.0, lo_open=True)
    else:
        if motor_speed_rpm is not None:
            raise ValueError("motor_speed_rpm must be None for scheme 3, got "
                             f"{motor_speed_rpm!r}")
        rpm = None
    direction = _validate_int("direction", direction, allowed=(1, -1))
    temp0 = _check_number("temp_joint_c", temp_joint_c, 15.0, 60.0)
    eff = _validate_effects(effects)
    if sensors is None:
        sensors = SensorSpec()
    elif not isinstance(sensors, SensorSpec):
        raise ValueError(f"sensors must be a SensorSpec, got {sensors!r}")
    periods = _validate_int("periods", periods, lo=1, hi=20)
    seed = _validate_int("seed", seed, lo=0)
    run = _validate_int("run", run, lo=0)
    unstated_scale = _check_number("unstated_scale", unstated_scale, 0.0, SCALE_MAX)

    m = _machine(seed)
    P = _param_vector(m, scheme, direction, rpm, unstated_scale)
    E = np.zeros(NF, dtype=np.int64)
    S = np.zeros(NF)
    for name, spec in eff.items():
        if name in _FAMILY_INDEX and spec["scale"] > 0:
            i = _FAMILY_INDEX[name]
            E[i] = EFFECT_FORMS[name].index(spec["form"]) + 1
            S[i] = spec["scale"]
    dur, tb, vb, phases = _schedule(scheme, periods)
    fa, fb = _fourier_unit()
    vmax = 0.9 * 3000.0 * 2 * math.pi / 60.0 / REDUCTION
    fa, fb = fa * vmax, fb * vmax

    fs = sensors.sample_rate_hz
    dts = 1.0 / fs
    n_sub = max(1, int(math.ceil(dts / H_MAX - 1e-9)))
    h = dts / n_sub
    n_samples = int(math.floor(dur * fs + 1e-9)) + 1
    y0 = _initial_state(P)
    temps0 = np.array([temp0, temp0 + 2.0, temp0 + 2.0, temp0 + 2.0])
    fine, ys, auxs, temps, nfail, njac = _simulate(y0, P, E, S, tb, vb, fa, fb, n_samples,
                                                   n_sub, h, temps0, _ATOL, _TYP)
    if nfail < 0:
        raise RuntimeError("rig_x: the integrator failed to converge")
    t = np.arange(n_samples) * dts

    # --- truth
    q = ys[:, 8]
    u_true = q + ys[:, 6] + ys[:, 0]
    truth = pd.DataFrame({
        "t": t, "q": q, "qd": ys[:, 9], "qdd": auxs[:, A_QDD], "u": u_true,
        "twist": auxs[:, A_TWIST], "torque": auxs[:, A_T], "torque_load": auxs[:, A_TL],
        "torque_elastic": auxs[:, A_TEL], "friction": auxs[:, A_FF],
        "torque_body": auxs[:, A_TBODY], "torque_cmd": auxs[:, A_TCMD],
        "m1": auxs[:, A_M1], "m2": auxs[:, A_M2], "m3": auxs[:, A_M3],
        "temp_joint": temps[:, 0],
    })

    # --- readings (noise drawn in a fixed order, independent of the effects)
    rng = np.random.default_rng([seed, run, 0x5E45])
    n = n_samples
    nz_torque = rng.standard_normal(n)
    nz_load = rng.standard_normal(n)
    nz_cur = rng.standard_normal((3, n))
    nz_spd = rng.standard_normal((3, n))

    tf, Tf, qf = fine[:, 0], fine[:, 1], fine[:, 3]
    td = eff.get("time_delay")
    extra_lag, tau_f, enc_lag = 0.0, 0.0, 0.0
    if td is not None and td["scale"] > 0:
        if td["form"] == "torque_pure_lag":
            extra_lag = td["scale"] * DELAY_TORQUE
        elif td["form"] == "torque_filter_lag":
            tau_f = td["scale"] * DELAY_TORQUE
        else:
            enc_lag = td["scale"] * DELAY_ENC
    Tin = _first_order(tf, Tf, tau_f)
    torque_rd = _sinc3_read(t, tf, Tin, sensors.torque_lag_s + extra_lag, h)
    to = eff.get("torque_offset")
    if to is not None and to["scale"] > 0:
        if to["form"] == "constant":
            torque_rd = torque_rd + to["scale"] * OFFSET_A
        elif to["form"] == "linear_drift":
            torque_rd = torque_rd + to["scale"] * OFFSET_A * t / 60.0
        else:
            torque_rd = torque_rd + to["scale"] * OFFSET_A * (1.0 - np.exp(-t / 20.0))
    torque_rd = torque_rd + sensors.torque_noise * nz_torque

    q_in = q if enc_lag == 0.0 else np.interp(t - enc_lag, tf, qf)
    ed = eff.get("encoder_drift")
    if ed is not None and ed["scale"] > 0:
        if ed["form"] == "linear":
            q_in = q_in + ed["scale"] * DRIFT_RATE * t
        else:
            q_in = q_in + ed["scale"] * DRIFT_SETTLE * (1.0 - np.exp(-t / 30.0))
    res_q = math.radians(sensors.encoder_res_deg)
    q_rd = np.round(q_in / res_q) * res_q
    res_u = 2 * math.pi / sensors.motor_encoder_counts / REDUCTION
    u_rd = np.round(u_true / res_u) * res_u

    N = REDUCTION
    cols: dict[str, Any] = {"t": t, "q": q_rd, "u": u_rd, "torsion": q_rd - u_rd,
                            "torque": torque_rd,
                            "torque_load": auxs[:, A_TL] + sensors.load_cell_noise * nz_load,
                            "torque_cmd": auxs[:, A_TCMD]}
    for j in range(3):
        cols[f"i_m{j + 1}"] = auxs[:, A_M1 + j] / (N * m["k_t"]) \
            + sensors.current_noise * nz_cur[j]
    for j in range(3):
        cols[f"w_m{j + 1}"] = ys[:, 3 + j] * N + sensors.speed_noise * nz_spd[j]

    def tq(x: np.ndarray) -> np.ndarray:
        r = sensors.temp_res_c
        return x if r == 0 else np.round(x / r) * r
    for j in range(3):
        cols[f"temp_m{j + 1}"] = tq(temps[:, 1 + j])
    cols["temp_joint"] = tq(temps[:, 0])
    phase = np.empty(n, dtype=object)
    for (a, b, name) in phases:
        phase[(t >= a - 1e-9) & (t < b - 1e-9)] = name
    phase[t >= phases[-1][1] - 1e-9] = phases[-1][2]
    cols["phase"] = phase
    samples = pd.DataFrame(cols)

    started = datetime(2026, 3, 2, 8, 0, tzinfo=timezone.utc) + timedelta(days=seed % 1000,
                                                                           minutes=10 * run)
    meta = {
        "scheme": scheme, "motor_speed_rpm": rpm, "direction": direction,
        "reduction": REDUCTION, "rig": RIG_NAME, "source": "emulator", "sample_rate_hz": fs,
        "started_at": started.strftime("%Y-%m-%dT%H:%M:%SZ"),
        "notes": f"rig_x validation rig, scheme {scheme}",
        "sensors": {
            "q": {"resolution": res_q, "noise_sd": 0.0, "lag_s": 0.0},
            "u": {"resolution": res_u, "noise_sd": 0.0, "lag_s": 0.0},
            # resolution 0: the reading is not quantised (a 24-bit ADC's step is far below noise)
            "torque": {"resolution": 0.0, "noise_sd": sensors.torque_noise,
                       "lag_s": sensors.torque_lag_s},
            "torque_load": {"resolution": 0.0, "noise_sd": sensors.load_cell_noise,
                            "lag_s": 0.0},
            **{f"i_m{j}": {"resolution": 0.0, "noise_sd": sensors.current_noise, "lag_s": 0.0}
               for j in (1, 2, 3)},
            **{f"w_m{j}": {"resolution": 0.0, "noise_sd": sensors.speed_noise, "lag_s": 0.0}
               for j in (1, 2, 3)},
            **{c: {"resolution": sensors.temp_res_c, "noise_sd": 0.0, "lag_s": 0.0}
               for c in ("temp_joint", "temp_m1", "temp_m2", "temp_m3")},
        },
    }
    params = {
        "machine": m,
        "effects": {k: dict(v) for k, v in eff.items()},
        "unstated": {k: {kk: (vv * unstated_scale if kk in ("mu", "lambda_per_c",
                                                            "amplitude_nm") else vv)
                         for kk, vv in v.items()} for k, v in UNSTATED_VALUES.items()},
        "unstated_scale": unstated_scale,
        "sensors": asdict(sensors),
        "scheme": scheme, "motor_speed_rpm": rpm, "direction": direction,
        "temp_joint_c": temp0, "periods": periods, "seed": seed, "run": run,
        "duration_s": float(t[-1]), "inner_step_s": h, "load_breakpoints": (tb.tolist(),
                                                                            vb.tolist()),
        "fourier_speed_coeffs": {"a": fa.tolist(), "b": fb.tolist(), "period_s": PERIOD_S},
        "integrator_jacobians": int(njac),
        "integrator_step_splits": int(nfail),
    }
    return RigRun(samples=samples, meta=meta, truth=truth, params=params)
