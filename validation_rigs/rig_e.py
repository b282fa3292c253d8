"""Validation rig E: an independently written simulator of the J4 heavy-joint test rig.

Data sheet (SI units, angles referred to the joint output unless said otherwise; temperatures °C).
Used only to score the sim-to-real diagnosis blind; it imports nothing of this repository.

1. Mechanics (nominal values; each campaign draws its own rig within the stated spread)
   Output:     I·q̈ = T − τ_L − g·(mr_x·sin q + mr_y·cos q) − F_f
               I = 6685 kg·m² (±4 %), mr_x = 20.8 kg·m, mr_y = −34.5 kg·m (±5 %), g = 9.81 m/s².
   Friction (output bearings/seals, between the torque transducer and the output), a Dahl
   presliding state z ∈ [−1, 1] driven by the output displacement (rate independent):
               dz = (sgn(dq) − z)·(1 − exp(−|dq|/δ)),  δ = 1.5e-5 rad (presliding distance)
               F_f = F_c·z + f_v·q̇,  F_c = 2353 N·m (±10 %), f_v = 8683 N·m·s/rad (±10 %)
               (no Stribeck rise, no temperature, load or direction dependence at nominal).
   Transmission (three motors → precision reducer → differential planetary, N = 11000), twist
   Δ = u − q:  T = k(Δ)·Δ + D·Δ̇,  k(Δ) = k_0·(1 + κ·(Δ/Δ_r)²)  (mildly stiffening),
               k_0 = 1.37e7 N·m/rad (±8 %, ≈0.5° at 120 kN·m), κ = 0.05 (0.03–0.07),
               Δ_r = 8.7e-3 rad; D = η_s·k_0/ω_1, structural loss factor η_s = 0.08 taken as the
               equivalent viscous damping at the first mode ω_1 = √(k_0/I).
   Motors:     J_r·ü = N·Σ k_t,j·i_j − N·τ_fm(ω) − T − μ_g·|T|·tanh(ω/ω_ε),
               ω = N·u̇ (motor rad/s), ω_ε = 1 rad/s,
               J_r = 3·0.003 kg·m²·N² (motor + first stage), k_t,j = 1.9 N·m/A (±3 % each),
               τ_fm = 0.25·tanh(ω/ω_ε) + 2e-4·ω N·m (motor side), mesh loss μ_g = 0.04 (seen in
               the currents only: the transducer sits after the gearbox).
               Current loops first order, τ_i,j = 1.2 ms (±15 %), limit ±25 A; one speed loop
               (PI, 150 rad/s crossover on the lumped motor) shares one current command; scheme 3
               closes a position loop on u (5 /s) around it with velocity feed-forward.
   Dynamometer: a hydraulic rotary actuator with its own pressure dynamics, in torque units
               τ̇_L = k_h·(q̇ − q_v) − τ_L/τ_leak,  q̇_v = (q_v,cmd − q_v)/τ_v,
               q_v,cmd = q̇ − (K_p·e + K_i·∫e) + τ_set/(k_h·τ_leak),  e = τ_set + d(t) − τ_L,
               k_h = 4e6 N·m/rad (±10 %), τ_leak = 5 s, τ_v = 8 ms, K_p = 1/(k_h·0.04 s),
               K_i = 5·K_p; d(t) an Ornstein–Uhlenbeck set-point error (sd 250 N·m, 3 s), drawn
               per run (the ±2 kN·m load error of the platform).
   Joint temperature: C·Ṫ = P_loss − G·(T_j − T_amb), C = 8e4 J/K, G = 20 W/K,
               T_amb = 20 °C (±2), P_loss = friction power + motor-side and mesh losses + 20 % of
               the copper losses (R = 1.1 Ω per motor).
   Integration: explicit Heun (RK2) at a fixed 0.5 ms step (numba); the Dahl and hysteresis
   states are advanced after each step from the position increments (operator splitting).
   The direction d = ±1 signs the motor speed, the trajectory and the load set point (the
   dynamometer always resists the motion: the joint drives).

2. Schemes
   1: rest 1 s, motor accelerates to d·rpm in 1 s, 2 s at speed ("idle"), τ_set ramps 0 → d·120 kN·m
      in 44 s ("load") and back in 44 s ("unload"), 8 s at speed ("idle"); 100 s.
   2: rest/accelerate as scheme 1 (4 s "idle"), 12 steps of 10 kN·m each ramped in 1 s ("load") and
      held 2 s ("hold"), unload in 15 s ("unload"), 5 s "idle"; 60 s.
   3: 3 s rest ("idle"), `periods` periods of a 20 s fifth-order Fourier trajectory
      q_ref = Σ a_k/(kω)·sin(kωt) − b_k/(kω)·(cos(kωt) − 1) with zero velocity and acceleration at
      its ends, peak speed 0.025 rad/s ("excite"), 3 s rest; τ_set = 0.

3. Sensors (SensorSpec); every channel is sampled at `sample_rate_hz` from the 2 kHz model.
   q: output encoder, rounded to encoder_res_deg.  u: motor encoder (motor_encoder_counts per
   motor revolution) / N.  qd: centred difference of the quantised encoder over 0.1 s.
   ud: centred difference of u over 20 ms.  torque: strain-gauge transducer between gearbox and
   output, amplifier low-pass τ_f = 2 ms, then a pure delay torque_lag_s, then white noise
   torque_noise.  torque_load: load cell on the loading shaft, low-pass 5 ms, noise
   load_noise.  temp_joint: PT100 rounded to 0.1 °C.  i_m1..3: currents with noise current_noise.
   w_m1..3: motor speeds from the motor encoders (N·ud) with noise speed_noise.
   The stated torque lag (meta) is τ_f + torque_lag_s.

4. Injected effects: `effects = {name: {"form": f, "scale": s}}`; every size below is the s = 1 size
   and scales linearly with s; s = 0 gives the nominal run bit for bit.
   stribeck (added to F_c, times z; v_s = 2.5e-3 rad/s, ΔF_s = 1400 N·m):
     exponential exp(−|v|/v_s); gaussian exp(−(v/v_s)²); lorentzian 1/(1 + (v/v_s)²);
     root exp(−√(|v|/v_s)).
   temperature_friction (T_j the gearbox temperature):
     viscous_exponential Δf_v = 1.5·f_v·exp(−0.04·(T_j − 20));
     coulomb_exponential ΔF_c = 0.25·F_c·exp(−(T_j − 15)/25);
     vogel_multiplicative F_c, f_v, Stribeck × (1 + 0.35·exp(700·(1/(T_j + 95) − 1/135))).
   load_dependent_friction (|T| the transmitted torque):
     coulomb_linear ΔF_c = 0.02·|T|; coulomb_and_viscous ΔF_c = 0.012·|T|, Δf_v = f_v·|T|/60 kN·m;
     power_flow ΔF_c = 0.025·|T| when T·q̇ > 0 (driving), 0.008·|T| otherwise;
     quadratic ΔF_c = 2400·(T/120 kN·m)².
   asymmetric_friction: coulomb_level F_c·(1 + 0.15·sgn z); viscous_slope f_v·(1 + 0.8·sgn q̇);
     positive_side F_c·(1 + 0.2·[z > 0]), f_v·(1 + 0.6·[q̇ > 0]).
   gear_ripple: output_mesh, a torque on the output (output-stage mesh, after the transducer)
       −700·(sin 48q + 0.35 sin(96q + 0.9) + 0.12 sin(144q + 2.1)) N·m;
     intermediate_error, a kinematic error in the transmission (seen in the twist)
       Δ −= 5e-5·(sin 220u + 0.3 sin(440u + 0.5)) rad;
     load_modulated, a torque on the output −900·(0.25 + |T|/120 kN·m)·sin(30q + 0.3) N·m.
   backlash (half play h = 1.5e-4 rad in the twist): sharp dead zone; smooth Δ − h·tanh(Δ/h);
     preload_closing sharp dead zone of half width h·30 kN·m/(30 kN·m + |τ_L|).
   hysteresis (T += H·x, x ∈ [−1, 1] driven by the twist increments):
     bouc_wen_n1 dx = dΔ/Δ_y·(1 − (0.6·sgn(dΔ·x) + 0.4)·|x|), H = 2500 N·m, Δ_y = 3e-4 rad;
     bouc_wen_n3 same with |x|³; dahl dx = dΔ/Δ_y·(1 − sgn(dΔ)·x)^1.5;
     soft_windup dx = dΔ/Δ_y'·(1 − sgn(dΔ)·x), Δ_y' = 1e-3 rad, T += H·x·(1 + (Δ/Δ_r)²).
   torque_offset (added to the reading): constant 600 N·m; linear_drift 800 N·m·t/100 s;
     thermal_settling 900·(1 − exp(−t/30 s)) N·m; temperature_coefficient 25 N·m/K·(T_j − 20).
   time_delay (of the torque reading only): pure_delay 40 ms; first_order τ = 40 ms;
     second_order two cascaded lags of 20 ms.
   Out of the vocabulary:
   pump_pulsation torque on the output 500·(sin 2π·2.7t + 0.3·sin(2π·5.4t + 1)) N·m;
   position_dependent_stiffness k_0 × max(0.2, 1 + 0.12·cos(2q + 0.4)) (never below 20 % of k_0);
   second_resonance a 1500 kg·m² appendage on the output, 3 Hz, ζ = 0.02 (inertia and spring × s);
   load_cell_gain_error torque_load reading × (1 + 0.03).
"""
from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import numpy as np
import pandas as pd
from numba import njit

SEED_IS_CAMPAIGN = True
REDUCTION = 11000.0
RIG_NAME = "validation-rig-E"
DT = 5e-4  # internal integration step, s

EFFECT_FORMS: dict[str, tuple[str, ...]] = {
    "stribeck": ("exponential", "gaussian", "lorentzian", "root"),
    "temperature_friction": ("viscous_exponential", "coulomb_exponential", "vogel_multiplicative"),
    "load_dependent_friction": ("coulomb_linear", "coulomb_and_viscous", "power_flow", "quadratic"),
    "asymmetric_friction": ("coulomb_level", "viscous_slope", "positive_side"),
    "gear_ripple": ("output_mesh", "intermediate_error", "load_modulated"),
    "backlash": ("sharp", "smooth", "preload_closing"),
    "hysteresis": ("bouc_wen_n1", "bouc_wen_n3", "dahl", "soft_windup"),
    "torque_offset": ("constant", "linear_drift", "thermal_settling", "temperature_coefficient"),
    "time_delay": ("pure_delay", "first_order", "second_order"),
    "pump_pulsation": ("two_lines",),
    "position_dependent_stiffness": ("cos2",),
    "second_resonance": ("appendage_3hz",),
    "load_cell_gain_error": ("gain",),
}
OUT_OF_VOCABULARY: tuple[str, ...] = (
    "pump_pulsation", "position_dependent_stiffness", "second_resonance", "load_cell_gain_error")

# Effects simulated inside the kernel: row index in the kernel's effect table.
_KERNEL_EFFECTS = ("stribeck", "temperature_friction", "load_dependent_friction",
                   "asymmetric_friction", "gear_ripple", "backlash", "hysteresis",
                   "pump_pulsation", "position_dependent_stiffness", "second_resonance")
_E = {name: i for i, name in enumerate(_KERNEL_EFFECTS)}
E_STRIBECK = 0
E_TEMPERATURE_FRICTION = 1
E_LOAD_DEPENDENT_FRICTION = 2
E_ASYMMETRIC_FRICTION = 3
E_GEAR_RIPPLE = 4
E_BACKLASH = 5
E_HYSTERESIS = 6
E_PUMP_PULSATION = 7
E_POSITION_DEPENDENT_STIFFNESS = 8
E_SECOND_RESONANCE = 9

# Parameter vector indices for the kernel.
(P_I, P_MRX, P_MRY, P_FC, P_FV, P_DELTA, P_K0, P_KAPPA, P_DREF, P_D, P_JR, P_KT1, P_KT2, P_KT3,
 P_TI1, P_TI2, P_TI3, P_IMAX, P_KPW, P_KIW, P_CM, P_BM, P_MUG, P_KH, P_TLEAK, P_TV, P_KPH, P_KIH,
 P_CTH, P_GTH, P_TAMB, P_RCU, P_MODE, P_KPOS, P_N) = range(35)
_NP = 35
G = 9.81
# Fine-grid output columns of the kernel.
(C_Q, C_QD, C_U, C_UD, C_T, C_TL, C_TJ, C_I1, C_I2, C_I3, C_FF) = range(11)
_NC = 11
_NS = 14  # continuous states: q qd u ud i1 i2 i3 Iw tauL qv Ih q2 q2d Tj


@dataclass(frozen=True)
class SensorSpec:
    """What the rig's sensors resolve; see the module docstring."""
    sample_rate_hz: float = 100.0
    encoder_res_deg: float = 0.001
    torque_noise: float = 150.0
    torque_lag_s: float = 0.0
    load_noise: float = 200.0
    motor_encoder_counts: int = 65536
    current_noise: float = 0.01
    speed_noise: float = 0.05
    temp_resolution_c: float = 0.1


@dataclass
class RigRun:
    """One simulated run: sampled channels, metadata, and the noise-free truth."""
    samples: pd.DataFrame
    meta: dict
    truth: pd.DataFrame


# ----------------------------------------------------------------------------- kernel
@njit(cache=True)
def _sgn(x: float) -> float:
    return 1.0 if x > 0.0 else (-1.0 if x < 0.0 else 0.0)


@njit(cache=True)
def _deriv(y, dy, t, wset, qref, qdref, tset, z, xh, P, E, aux):
    """Right-hand side of the continuous states; aux receives T, F_f, τ_m."""
    N = P[P_N]
    q = y[0]
    qd = y[1]
    u = y[2]
    ud = y[3]
    tj = y[13]
    tauL = y[8]
    # ---- transmission
    d = u - q
    dd = ud - qd
    de = d
    slope = 1.0
    f = int(E[E_BACKLASH, 0])
    if f >= 0:
        h = abs(E[E_BACKLASH, 1]) * 1.5e-4
        if f == 2:
            h = h * 30e3 / (30e3 + abs(tauL))
        if f == 1:
            if h > 0.0:
                th = math.tanh(d / h)
                de = d - h * th
                slope = th * th
        else:
            if d > h:
                de = d - h
            elif d < -h:
                de = d + h
            else:
                de = 0.0
                slope = 0.0
    dde = slope * dd
    f = int(E[E_GEAR_RIPPLE, 0])
    s_r = E[E_GEAR_RIPPLE, 1]
    if f == 1:
        zu = 220.0
        de -= s_r * 5e-5 * (math.sin(zu * u) + 0.3 * math.sin(2.0 * zu * u + 0.5))
        dde -= s_r * 5e-5 * zu * ud * (math.cos(zu * u) + 0.6 * math.cos(2.0 * zu * u + 0.5))
    r = de / P[P_DREF]
    k = P[P_K0] * (1.0 + P[P_KAPPA] * r * r)
    f = int(E[E_POSITION_DEPENDENT_STIFFNESS, 0])
    if f >= 0:
        k *= max(0.2, 1.0 + E[E_POSITION_DEPENDENT_STIFFNESS, 1] * 0.12 * math.cos(2.0 * q + 0.4))
    T = k * de + P[P_D] * dde
    f = int(E[E_HYSTERESIS, 0])
    if f >= 0:
        H = E[E_HYSTERESIS, 1] * 2500.0
        if f == 3:
            T += H * xh * (1.0 + r * r)
        else:
            T += H * xh
    # ---- output friction
    fc = P[P_FC]
    fv = P[P_FV]
    fmag = fc
    sz = 1.0 if z >= 0.0 else -1.0
    f = int(E[E_ASYMMETRIC_FRICTION, 0])
    if f >= 0:
        s = E[E_ASYMMETRIC_FRICTION, 1]
        if f == 0:
            fmag += s * 0.15 * fc * sz
        elif f == 1:
            fv = fv * (1.0 + s * 0.8 * _sgn(qd))
        else:
            if z > 0.0:
                fmag += s * 0.2 * fc
            if qd > 0.0:
                fv = fv + s * 0.6 * P[P_FV]
    f = int(E[E_STRIBECK, 0])
    if f >= 0:
        x = abs(qd) / 2.5e-3
        if f == 0:
            g = math.exp(-x)
        elif f == 1:
            g = math.exp(-x * x)
        elif f == 2:
            g = 1.0 / (1.0 + x * x)
        else:
            g = math.exp(-math.sqrt(x))
        fmag += E[E_STRIBECK, 1] * 1400.0 * g
    f = int(E[E_LOAD_DEPENDENT_FRICTION, 0])
    if f >= 0:
        s = E[E_LOAD_DEPENDENT_FRICTION, 1]
        aT = abs(T)
        if f == 0:
            fmag += s * 0.02 * aT
        elif f == 1:
            fmag += s * 0.012 * aT
            fv += s * P[P_FV] * aT / 60e3
        elif f == 2:
            mu = 0.025 if T * qd > 0.0 else 0.008
            fmag += s * mu * aT
        else:
            rr = T / 120e3
            fmag += s * 2400.0 * rr * rr
    f = int(E[E_TEMPERATURE_FRICTION, 0])
    if f >= 0:
        s = E[E_TEMPERATURE_FRICTION, 1]
        if f == 0:
            fv += s * 1.5 * P[P_FV] * math.exp(-0.04 * (tj - 20.0))
        elif f == 1:
            fmag += s * 0.25 * P[P_FC] * math.exp(-(tj - 15.0) / 25.0)
        else:
            m = 1.0 + s * 0.35 * math.exp(700.0 * (1.0 / (tj + 95.0) - 1.0 / 135.0))
            fmag *= m
            fv *= m
    ff = fmag * z + fv * qd
    grav = G * (P[P_MRX] * math.sin(q) + P[P_MRY] * math.cos(q))
    extra = 0.0
    f = int(E[E_GEAR_RIPPLE, 0])
    if f == 0:
        extra -= s_r * 700.0 * (math.sin(48.0 * q) + 0.35 * math.sin(96.0 * q + 0.9)
                                + 0.12 * math.sin(144.0 * q + 2.1))
    elif f == 2:
        extra -= s_r * 900.0 * (0.25 + abs(T) / 120e3) * math.sin(30.0 * q + 0.3)
    f = int(E[E_PUMP_PULSATION, 0])
    if f >= 0:
        extra += E[E_PUMP_PULSATION, 1] * 500.0 * (
            math.sin(2.0 * math.pi * 2.7 * t) + 0.3 * math.sin(2.0 * math.pi * 5.4 * t + 1.0))
    f = int(E[E_SECOND_RESONANCE, 0])
    if f >= 0:
        s = E[E_SECOND_RESONANCE, 1]
        i2 = s * 1500.0
        k2 = i2 * (2.0 * math.pi * 3.0) ** 2
        c2 = 2.0 * 0.02 * math.sqrt(k2 * i2)
        tc = k2 * (y[11] - q) + c2 * (y[12] - qd)
        extra += tc
        dy[11] = y[12]
        dy[12] = -tc / i2
    else:
        dy[11] = 0.0
        dy[12] = 0.0
    dy[0] = qd
    dy[1] = (T - tauL - grav - ff + extra) / P[P_I]
    # ---- motors: speed loop (and position loop in scheme 3), current loops
    w = N * ud
    if P[P_MODE] > 0.5:
        ws = N * (qdref + P[P_KPOS] * (qref - u))
    else:
        ws = wset
    ew = ws - w
    tcmd = P[P_KPW] * ew + y[7]
    ktn = (P[P_KT1] + P[P_KT2] + P[P_KT3])
    icmd = tcmd / ktn
    sat = False
    if icmd > P[P_IMAX]:
        icmd = P[P_IMAX]
        sat = True
    elif icmd < -P[P_IMAX]:
        icmd = -P[P_IMAX]
        sat = True
    dy[4] = (icmd - y[4]) / P[P_TI1]
    dy[5] = (icmd - y[5]) / P[P_TI2]
    dy[6] = (icmd - y[6]) / P[P_TI3]
    dy[7] = 0.0 if (sat and ew * tcmd > 0.0) else P[P_KIW] * ew
    tm = P[P_KT1] * y[4] + P[P_KT2] * y[5] + P[P_KT3] * y[6]
    tfm = P[P_CM] * math.tanh(w) + P[P_BM] * w
    mesh = P[P_MUG] * abs(T) * math.tanh(w)
    dy[2] = ud
    dy[3] = (N * tm - N * tfm - T - mesh) / P[P_JR]
    # ---- hydraulic dynamometer
    e = tset - tauL
    qvcmd = qd - (P[P_KPH] * e + y[10]) + tset / (P[P_KH] * P[P_TLEAK])
    dy[9] = (qvcmd - y[9]) / P[P_TV]
    dy[8] = P[P_KH] * (qd - y[9]) - tauL / P[P_TLEAK]
    dy[10] = P[P_KIH] * e
    # ---- gearbox temperature
    ploss = (abs(ff * qd) + abs(N * tfm * ud) + abs(mesh * ud)
             + 0.2 * P[P_RCU] * (y[4] ** 2 + y[5] ** 2 + y[6] ** 2))
    dy[13] = (ploss - P[P_GTH] * (tj - P[P_TAMB])) / P[P_CTH]
    aux[0] = T
    aux[1] = ff
    aux[2] = tm


@njit(cache=True)
def _hyst_step(x, dD, form):
    """Advance the normalised hysteresis state by a twist increment dD (rad)."""
    dy = 1e-3 if form == 3 else 3e-4
    m = int(abs(dD) / (0.05 * dy)) + 1
    if m > 400:
        m = 400
    h = dD / m / dy
    sd = 1.0 if h >= 0.0 else -1.0
    for _ in range(m):
        if form == 0 or form == 1:
            sg = 1.0 if h * x >= 0.0 else -1.0
            ax = abs(x) if form == 0 else abs(x) ** 3
            x += h * (1.0 - (0.6 * sg + 0.4) * ax)
        elif form == 2:
            rr = 1.0 - sd * x
            if rr < 0.0:
                rr = 0.0
            x += h * rr ** 1.5
        else:
            x += h * (1.0 - sd * x)
        if x > 1.0:
            x = 1.0
        elif x < -1.0:
            x = -1.0
    return x


@njit(cache=True)
def _simulate(n, dt, P, E, y0, wset, qref, qdref, tset, out):
    """Integrate n fine steps (Heun); out[k] holds the state at t = k·dt."""
    y = y0.copy()
    k1 = np.zeros(_NS)
    k2 = np.zeros(_NS)
    yt = np.zeros(_NS)
    aux = np.zeros(3)
    aux2 = np.zeros(3)
    z = 0.0
    xh = 0.0
    delta = P[P_DELTA]
    hform = int(E[E_HYSTERESIS, 0])
    for k in range(n):
        t = k * dt
        _deriv(y, k1, t, wset[k], qref[k], qdref[k], tset[k], z, xh, P, E, aux)
        out[k, C_Q] = y[0]
        out[k, C_QD] = y[1]
        out[k, C_U] = y[2]
        out[k, C_UD] = y[3]
        out[k, C_T] = aux[0]
        out[k, C_TL] = y[8]
        out[k, C_TJ] = y[13]
        out[k, C_I1] = y[4]
        out[k, C_I2] = y[5]
        out[k, C_I3] = y[6]
        out[k, C_FF] = aux[1]
        if k == n - 1:
            break
        for j in range(_NS):
            yt[j] = y[j] + dt * k1[j]
        _deriv(yt, k2, t + dt, wset[k + 1], qref[k + 1], qdref[k + 1], tset[k + 1], z, xh, P, E,
               aux2)
        dq = -y[0]
        dD = -(y[2] - y[0])
        for j in range(_NS):
            y[j] += 0.5 * dt * (k1[j] + k2[j])
        dq += y[0]
        dD += y[2] - y[0]
        if dq != 0.0:
            sd = 1.0 if dq > 0.0 else -1.0
            z = sd + (z - sd) * math.exp(-abs(dq) / delta)
        if hform >= 0:
            xh = _hyst_step(xh, dD, hform)
    return out


# ----------------------------------------------------------------------------- schedules
def _ramp(t: np.ndarray, t0: float, t1: float) -> np.ndarray:
    return np.clip((t - t0) / (t1 - t0), 0.0, 1.0)


def _fourier_coefficients() -> tuple[np.ndarray, np.ndarray, float]:
    """Velocity coefficients a_k, b_k (rad/s) with zero start velocity and acceleration."""
    a = np.array([1.0, -0.5, 0.3, -0.4, 0.0])
    a[4] = -a[:4].sum()
    b = np.array([0.6, 0.4, -0.5, 0.3, 0.0])
    b[4] = -(np.arange(1, 5) * b[:4]).sum() / 5.0
    wf = 2.0 * np.pi / 20.0
    tt = np.linspace(0.0, 20.0, 4001)
    kk = np.arange(1, 6)[:, None]
    v = (a[:, None] * np.cos(kk * wf * tt) + b[:, None] * np.sin(kk * wf * tt)).sum(axis=0)
    scale = 0.025 / np.abs(v).max()
    return a * scale, b * scale, wf


_FA, _FB, _WF = _fourier_coefficients()


def _schedule(scheme: int, rpm: float, direction: int, periods: int, t: np.ndarray):
    """Set points on the fine grid: motor speed (motor rad/s), output position and rate
    references (scheme 3), and the dynamometer torque set point (N·m)."""
    zero = np.zeros_like(t)
    if scheme in (1, 2):
        w = direction * rpm * 2.0 * np.pi / 60.0 * _ramp(t, 1.0, 2.0)
        if scheme == 1:
            tset = direction * 120e3 * (_ramp(t, 4.0, 48.0) - _ramp(t, 48.0, 92.0))
        else:
            steps = np.zeros_like(t)
            for j in range(12):
                steps += _ramp(t, 4.0 + 3.0 * j, 5.0 + 3.0 * j)
            tset = direction * 10e3 * steps * (1.0 - _ramp(t, 40.0, 55.0))
        return w, zero, zero.copy(), tset
    te = np.clip(t - 3.0, 0.0, periods * 20.0)
    kk = np.arange(1, 6)[:, None]
    arg = kk * _WF * te
    qref = direction * ((_FA[:, None] / (kk * _WF)) * np.sin(arg)
                        - (_FB[:, None] / (kk * _WF)) * (np.cos(arg) - 1.0)).sum(axis=0)
    moving = (t > 3.0) & (t < 3.0 + periods * 20.0)
    qdref = direction * ((_FA[:, None] * np.cos(arg) + _FB[:, None] * np.sin(arg)).sum(axis=0))
    qdref = np.where(moving, qdref, 0.0)
    return zero, qref, qdref, zero.copy()


def _phase_labels(scheme: int, periods: int, ts: np.ndarray) -> np.ndarray:
    if scheme == 1:
        return np.select([ts < 4.0, ts < 48.0, ts < 92.0], ["idle", "load", "unload"], "idle")
    if scheme == 2:
        stepping = np.where(np.mod(ts - 4.0, 3.0) < 1.0, "load", "hold")
        return np.select([ts < 4.0, ts < 40.0, ts < 55.0], ["idle", stepping, "unload"], "idle")
    return np.where((ts >= 3.0) & (ts < 3.0 + periods * 20.0), "excite", "idle")


def _duration(scheme: int, periods: int) -> float:
    return {1: 100.0, 2: 60.0}.get(scheme, 6.0 + 20.0 * periods)


# ----------------------------------------------------------------------------- parameters
def _campaign_parameters(seed: int) -> np.ndarray:
    """The rig of one campaign, drawn from the data sheet's spreads."""
    rng = np.random.default_rng(np.random.SeedSequence([int(seed) % (2 ** 63), 0xE0E0]))
    P = np.zeros(_NP)
    P[P_N] = REDUCTION
    P[P_I] = 6685.0 * (1.0 + 0.04 * rng.uniform(-1, 1))
    P[P_MRX] = 20.8 * (1.0 + 0.05 * rng.uniform(-1, 1))
    P[P_MRY] = -34.5 * (1.0 + 0.05 * rng.uniform(-1, 1))
    P[P_FC] = 2353.0 * (1.0 + 0.10 * rng.uniform(-1, 1))
    P[P_FV] = 8683.0 * (1.0 + 0.10 * rng.uniform(-1, 1))
    P[P_DELTA] = 1.5e-5
    P[P_K0] = 1.37e7 * (1.0 + 0.08 * rng.uniform(-1, 1))
    P[P_KAPPA] = rng.uniform(0.03, 0.07)
    P[P_DREF] = 8.7e-3
    P[P_D] = 0.08 * P[P_K0] / math.sqrt(P[P_K0] / P[P_I])
    P[P_JR] = 3 * 0.003 * REDUCTION ** 2
    kt = 1.9 * (1.0 + 0.03 * rng.uniform(-1, 1, 3))
    P[P_KT1], P[P_KT2], P[P_KT3] = kt
    ti = 1.2e-3 * (1.0 + 0.15 * rng.uniform(-1, 1, 3))
    P[P_TI1], P[P_TI2], P[P_TI3] = ti
    P[P_IMAX] = 25.0
    jm = 3 * 0.003
    P[P_KPW] = jm * 150.0
    P[P_KIW] = P[P_KPW] * 150.0 / 4.0
    P[P_CM] = 0.25
    P[P_BM] = 2e-4
    P[P_MUG] = 0.04
    P[P_KH] = 4e6 * (1.0 + 0.10 * rng.uniform(-1, 1))
    P[P_TLEAK] = 5.0
    P[P_TV] = 8e-3
    P[P_KPH] = 1.0 / (P[P_KH] * 0.04)
    P[P_KIH] = 5.0 * P[P_KPH]
    P[P_CTH] = 8e4
    P[P_GTH] = 20.0
    P[P_TAMB] = 20.0 + 2.0 * rng.uniform(-1, 1)
    P[P_RCU] = 1.1
    P[P_KPOS] = 5.0
    return P


def _parse_effects(effects: dict[str, dict]) -> dict[str, tuple[str, float]]:
    """Validate the effects; drop the ones with scale 0 (so s = 0 is the nominal run)."""
    active: dict[str, tuple[str, float]] = {}
    for name, spec in (effects or {}).items():
        if name not in EFFECT_FORMS:
            raise ValueError(f"unknown effect {name!r}; known: {sorted(EFFECT_FORMS)}")
        if not isinstance(spec, dict):
            raise ValueError(f"effect {name!r}: expected a dict with 'form' and 'scale'")
        form = spec.get("form", EFFECT_FORMS[name][0])
        if form not in EFFECT_FORMS[name]:
            raise ValueError(f"effect {name!r}: unknown form {form!r}; "
                             f"known: {EFFECT_FORMS[name]}")
        scale = float(spec.get("scale", 1.0))
        if not math.isfinite(scale):
            raise ValueError(f"effect {name!r}: scale must be finite")
        if scale != 0.0:
            active[name] = (form, scale)
    return active


# ----------------------------------------------------------------------------- sensors
def _lowpass(x: np.ndarray, tau: float, dt: float) -> np.ndarray:
    """Exact first-order lag on the fine grid, starting at rest on x[0]."""
    if tau <= 0.0:
        return x
    a = math.exp(-dt / tau)
    return _lowpass_loop(x, a)


@njit(cache=True)
def _lowpass_loop(x, a):
    y = np.empty_like(x)
    acc = x[0]
    for i in range(x.shape[0]):
        acc = a * acc + (1.0 - a) * x[i]
        y[i] = acc
    return y


def _at(tf: np.ndarray, x: np.ndarray, ts: np.ndarray) -> np.ndarray:
    """Linear interpolation of a fine-grid signal, held at its ends."""
    return np.interp(ts, tf, x)


def _ou(rng: np.random.Generator, tf: np.ndarray, sd: float, tau: float) -> np.ndarray:
    """Ornstein–Uhlenbeck process on a 50 ms grid, interpolated to tf."""
    h = 0.05
    m = int(tf[-1] / h) + 2
    a = math.exp(-h / tau)
    e = rng.standard_normal(m) * sd * math.sqrt(1.0 - a * a)
    x = np.empty(m)
    x[0] = sd * rng.standard_normal()
    for i in range(1, m):
        x[i] = a * x[i - 1] + e[i]
    return np.interp(tf, np.arange(m) * h, x)


def simulate_run(scheme: int, motor_speed_rpm: float | None, direction: int, temp_joint_c: float,
                 effects: dict[str, dict], *, seed: int, sensors: SensorSpec, periods: int = 3,
                 run: int = 0) -> RigRun:
    """Simulate one run of scheme 1, 2 or 3 on campaign `seed`'s rig; `run` keys its noise."""
    if scheme not in (1, 2, 3):
        raise ValueError(f"scheme must be 1, 2 or 3, got {scheme!r}")
    if scheme in (1, 2) and (motor_speed_rpm is None or motor_speed_rpm <= 0):
        raise ValueError("schemes 1 and 2 need a positive motor_speed_rpm")
    if direction not in (1, -1):
        raise ValueError("direction must be +1 or -1")
    if scheme == 3 and periods < 1:
        raise ValueError("periods must be at least 1")
    fs = float(sensors.sample_rate_hz)
    if not (fs > 0.0):
        raise ValueError("sample_rate_hz must be positive")
    active = _parse_effects(effects)

    P = _campaign_parameters(seed)
    P[P_MODE] = 1.0 if scheme == 3 else 0.0
    rng = np.random.default_rng(np.random.SeedSequence([int(seed) % (2 ** 63), int(run), 0xE1]))

    duration = _duration(scheme, periods)
    n = int(round(duration / DT)) + 1
    tf = np.arange(n) * DT
    rpm = float(motor_speed_rpm) if motor_speed_rpm is not None else 0.0
    wset, qref, qdref, tset = _schedule(scheme, rpm, direction, periods, tf)
    tset = tset + _ou(rng, tf, 250.0, 3.0)

    E = np.zeros((len(_KERNEL_EFFECTS), 2))
    E[:, 0] = -1.0
    for name, (form, scale) in active.items():
        if name in _E:
            E[_E[name], 0] = EFFECT_FORMS[name].index(form)
            E[_E[name], 1] = scale

    y0 = np.zeros(_NS)
    grav0 = G * P[P_MRY]
    y0[2] = grav0 / P[P_K0]
    if "backlash" in active:
        y0[2] += math.copysign(abs(active["backlash"][1]) * 1.5e-4, grav0)
    y0[13] = float(temp_joint_c)
    out = np.zeros((n, _NC))
    _simulate(n, DT, P, E, y0, wset, qref, qdref, tset, out)

    # ---- sensors on the fine grid, then sampled
    ns = int(round(duration * fs))
    ts = np.arange(ns) / fs
    q_true = _at(tf, out[:, C_Q], ts)
    u_true = _at(tf, out[:, C_U], ts)
    qd_true = _at(tf, out[:, C_QD], ts)
    ud_true = _at(tf, out[:, C_UD], ts)
    tj = _at(tf, out[:, C_TJ], ts)
    T_true = _at(tf, out[:, C_T], ts)

    tau_f = 2e-3
    reading = _lowpass(out[:, C_T], tau_f, DT)
    extra_delay = 0.0
    if "time_delay" in active:
        form, s = active["time_delay"]
        if form == "pure_delay":
            extra_delay = s * 0.04
        elif form == "first_order":
            reading = _lowpass(reading, abs(s) * 0.04, DT)
        else:
            reading = _lowpass(_lowpass(reading, abs(s) * 0.02, DT), abs(s) * 0.02, DT)
    torque_clean = np.interp(ts - sensors.torque_lag_s - extra_delay, tf, reading)
    if "torque_offset" in active:
        form, s = active["torque_offset"]
        if form == "constant":
            torque_clean = torque_clean + s * 600.0
        elif form == "linear_drift":
            torque_clean = torque_clean + s * 800.0 * ts / 100.0
        elif form == "thermal_settling":
            torque_clean = torque_clean + s * 900.0 * (1.0 - np.exp(-ts / 30.0))
        else:
            torque_clean = torque_clean + s * 25.0 * (tj - 20.0)

    load_clean = _at(tf, _lowpass(out[:, C_TL], 5e-3, DT), ts)
    if "load_cell_gain_error" in active:
        load_clean = load_clean * (1.0 + 0.03 * active["load_cell_gain_error"][1])

    res_q = math.radians(sensors.encoder_res_deg)
    res_u = 2.0 * math.pi / sensors.motor_encoder_counts / REDUCTION

    def quant(x: np.ndarray, res: float) -> np.ndarray:
        return np.round(x / res) * res

    q_meas = quant(q_true, res_q)
    u_meas = quant(u_true, res_u)
    def rate(x: np.ndarray, res: float, window: float) -> np.ndarray:
        """Centred difference of the quantised encoder over `window`, one-sided at the ends."""
        hi = np.minimum(ts + window / 2, tf[-1])
        lo = np.maximum(ts - window / 2, 0.0)
        return (quant(_at(tf, x, hi), res) - quant(_at(tf, x, lo), res)) / (hi - lo)

    wq = 0.1
    qd_meas = rate(out[:, C_Q], res_q, wq)
    wu = 0.02
    ud_meas = rate(out[:, C_U], res_u, wu)

    torque_meas = torque_clean + sensors.torque_noise * rng.standard_normal(ns)
    load_meas = load_clean + sensors.load_noise * rng.standard_normal(ns)
    samples = {
        "t": ts, "q": q_meas, "qd": qd_meas, "u": u_meas, "ud": ud_meas,
        "torque": torque_meas, "torque_load": load_meas,
        "temp_joint": quant(tj, sensors.temp_resolution_c),
        "phase": _phase_labels(scheme, periods, ts),
    }
    for j, c in enumerate((C_I1, C_I2, C_I3)):
        samples[f"i_m{j + 1}"] = (_at(tf, out[:, c], ts)
                                  + sensors.current_noise * rng.standard_normal(ns))
    for j in range(3):
        samples[f"w_m{j + 1}"] = REDUCTION * ud_meas + sensors.speed_noise * rng.standard_normal(ns)

    truth = pd.DataFrame({
        "t": ts, "q": q_true, "qd": qd_true, "u": u_true, "ud": ud_true, "twist": u_true - q_true,
        "torque": torque_clean, "torque_load": load_clean, "torque_joint": T_true,
        "torque_load_true": _at(tf, out[:, C_TL], ts), "torque_friction": _at(tf, out[:, C_FF], ts),
        "temp_joint": tj,
    })
    meta = {
        "scheme": scheme,
        "motor_speed_rpm": None if scheme == 3 else float(motor_speed_rpm),
        "direction": int(direction),
        "reduction": 11000,
        "rig": RIG_NAME,
        "source": "emulator",
        "sample_rate_hz": fs,
        "duration_s": duration,
        "temp_joint_c": float(temp_joint_c),
        "sensors": {
            "q": {"resolution": res_q},
            "u": {"resolution": res_u},
            "qd": {"window_s": wq},
            "ud": {"window_s": wu},
            "torque": {"noise_sd": float(sensors.torque_noise),
                       "lag_s": float(tau_f + sensors.torque_lag_s)},
            "torque_load": {"noise_sd": float(sensors.load_noise), "lag_s": 5e-3},
            "temp_joint": {"resolution": float(sensors.temp_resolution_c)},
            "i_m1": {"noise_sd": float(sensors.current_noise)},
            "i_m2": {"noise_sd": float(sensors.current_noise)},
            "i_m3": {"noise_sd": float(sensors.current_noise)},
        },
        "sensor_spec": asdict(sensors),
    }
    if scheme == 3:
        meta["periods"] = int(periods)
    return RigRun(samples=pd.DataFrame(samples), meta=meta, truth=truth)
