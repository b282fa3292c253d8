"""rig_r — an independent validation rig of the CMOR joint-4 test bench (written from first
principles, sharing no code with simulators/ or core/terms.py).

Data sheet
==========

Machine (nominal values; each campaign draws its own machine from `seed`, spread in brackets,
normal, clipped at 2.5 sd)
--------------------------------------------------------------------------------------------
Output body (joint output flange + loading shaft), the paper's Eq. 4 with the load:

    I·q̈ = T − τ_L − g·(mr_x·sin q + mr_y·cos q) − F_fr + τ_extra

    I    = 6685.166 kg·m²  (±2 %)          mr_x = 20.779 kg·m  (±3 %)
    mr_y = −34.543 kg·m    (±3 %)          g    = 9.81 m/s²

Friction F_fr (output bearings, acting on the output body downstream of the torque transducer):
a LuGre-type bristle law WITHOUT a Stribeck dip at scale 0, so that steady sliding is exactly
Eq. 4 (`F = f_c·sgn(q̇) + f_v·q̇`) but reversals show presliding (a stiff bristle spring) and
stiction (the body sticks while the motor winds up the transmission):

    ż = q̇ − σ0·|q̇|·z / G(q̇),   F_fr = σ0·z + σ1·ż + f_v·q̇,   G = f_c (+ effects)
    f_c = 2352.660 N·m (±3 %)  f_v = 8683.272 N·m·s/rad (±3 %)
    σ0  = 1.2e8 N·m/rad (±10 %, presliding ≈ 2e-5 rad = 0.001°)   σ1 = 5.4e5 N·m·s/rad (±10 %)

Transmission (three motors → precision reducer → differential planetary, N = 11000), from the
motor angle referred to the output u to the output angle q; twist Δ = u − q:

    T = k·Δ·(1 + c3·(Δ/Δ_r)²) + D·Δ̇      (a hardening tooth-contact spring: NOT the textbook
                                             linear spring; stiffness +c3 at the rated twist)
    k  = 1.375e7 N·m/rad (±3 %; twist ≈ 0.5° at 120 kN·m)   c3 = 0.05 (±10 %)
    Δ_r = 120e3 / 1.375e7 rad (the nominal rated twist)       D  = 6.0e4 N·m·s/rad (±10 %)

Motor side (the three motors and the first reducer stage, referred to the output):

    J_r·ü = T_m − T − F_m(u̇),  J_r = 3·0.0125·N² kg·m²,  F_m = 1500·tanh(u̇/0.002) + 2e4·u̇
    T_m   = K_p·(ω_ref − u̇) + ∫K_i·(ω_ref − u̇) + J_r·ü_ref,  ω_ref = u̇_ref + K_pos·(u_ref − u)
    (S120 cascade: speed loop 40 rad/s, position loop 10 1/s, |T_m| ≤ 2.2e5 N·m referred)
    three motors share T_m with a drawn mismatch (±1 %); k_t = 2.0 N·m/A; currents
    i_k = share_k·T_m / (3·N·k_t).

Dynamometer (torque source on the output body): second order, 4 Hz, ζ = 0.8, tracking gain
1 ± 0.3 % and a 25 N·m cogging ripple at 2 cycles per dynamometer-motor revolution (dynamometer
reducer 60:1). All of it is what the load cell measures, so none of it is a model gap.

Thermal: gearbox lubricant T_oil heated by the losses P = |F_fr·q̇| + 0.03·|T·u̇|
(C_oil = 4000 J/K, exchanging with the housing in 90 s); the housing T_h (what the temp_joint
sensor reads) follows T_oil in 400 s and the ambient (= temp_joint_c at the start) in 3600 s.
Motor windings: first-order, 8 K above the joint at the start, R = 0.8 Ω, 60 K/kW, 600 s.

Integrator
----------
Classical fixed-step fourth-order Runge–Kutta (numba, cache=True) on 14 states, internal step
h0 = 0.2 ms; every sample instant lies on a step (h = 1/(fs·ceil(1/(fs·h0))) ≤ h0, equal to h0
for every rate dividing 5 kHz: 10, 20, 50, 100, 200, 250, 500, 1000 Hz ...). The
Prandtl–Ishlinskii play operators are updated exactly after each step.

Schemes (all start at rest at q = u = 0: the paper zeroes the joint and the output encoder)
-------------------------------------------------------------------------------------------
1. 63 s: standstill 2 s, accelerate (cosine ramp, 1.5 s) to `direction`·rpm·2π/60/N, idle to 5 s,
   load ramp 0 → 120 kN·m (5–30 s), hold (30–33 s), unload to 0 (33–58 s), idle, decelerate at
   59.5 s, idle. The dynamometer loads positively (the paper's positive loading) whatever the
   direction of motion.
2. 58 s: as 1 but loading in twelve 10 kN·m steps (1 s ramp 'load', 2 s pause 'hold') to
   120 kN·m (5–41 s), unload ramp 41–53 s.
3. periods × 16 s: fifth-order Fourier trajectory (Eq. 12), ω_f = 2π/16 s, coefficients
   a = [0.6, −0.2, 0.35, −0.5, −0.25], b = [0.5, 0.3, −0.4, 0.1, −0.06] (Σa = 0 and Σl·b_l = 0: it
   starts at rest), scaled to a peak speed 0.9 × 0.02856 rad/s, times `direction`; no load
   (dynamometer set point 0).

Sensors (stated in the metadata unless marked unstated)
-------------------------------------------------------
- q: output absolute encoder, rounded to `encoder_res_deg` (zeroed at the start).
- qd: the encoder interface's velocity from its full 24-bit interpolated count: 10 ms window
  difference, then a 5 ms first-order filter (stated lag 10 ms, resolution 2π/2^24/10 ms).
- u: motor encoder (2^20 counts per motor revolution) / N. ud: motor speed / N, 2 ms filter.
- torque: strain-gauge transducer between joint output and output body; amplifier two 0.16 ms
  poles (stated lag 0.32 ms + `torque_lag_s`), white noise sd `torque_noise`, 16-bit ADC over
  ±200 kN·m (6.1 N·m).
- torque_load: load cell of the loading device; same amplifier (stated lag 0.32 ms), noise sd
  `load_noise`, same ADC.
- torque_cmd: the dynamometer set point. temp_joint: housing sensor, 0.1 °C, noise 0.03 °C.
- i_m1..3 (noise 0.01 A), w_m1..3 (noise 0.05 rad/s), temp_m1..3, torsion = q − u (measured).

Unstated imperfections (drawn from `seed`, in params["unstated"]; small, as on a calibrated rig)
---------------------------------------------------------------------------------------------
- torque transducer zero offset, sd 30 N·m (clipped ±75), and a slow thermal zero drift,
  sd 8 N·m/min  → vocabulary "torque_offset";
- load-cell amplifier's extra first-order lag of 3–5 ms  → vocabulary "time_delay";
- torque transducer and load cell gain errors, sd 0.05 % each;
- temperature sensor offset, sd 0.2 °C; motor current sharing mismatch (±1 %).

Effects (name: form → form and size at scale s = 1; every contribution ∝ s for small s)
-----------------------------------------------------------------------------------------
stribeck — friction level G += s·ΔF·φ(|q̇|/v_s), ΔF = 0.25·f_c (≈ 590 N·m), v_s = 0.008 rad/s
    (≈ 840 r/min at the motor; the steepest negative slope stays below the drive-side damping
    at s = 1, so the 300 r/min runs slide smoothly; larger s may stick–slip):
    exp1: φ = e^(−x);  exp2: φ = e^(−x²);  lorentzian: φ = 1/(1+x²);  exp_half: φ = e^(−√x).
load_dependent_friction — with |T| the transmitted torque, T_r = 120 kN·m:
    coulomb: G += s·0.0035·|T| (420 N·m at rated);
    coulomb_viscous: G += s·0.002·|T|, f_v ·= 1 + s·0.5·|T|/T_r;
    power_flow: G += s·μ·|T|, μ = 0.004 when the joint drives the load (T·q̇ > 0), 0.0015
      when back-driven;
    quadratic: G += s·0.004·T²/T_r (480 N·m at rated).
temperature_friction — on the lubricant temperature T_oil, T_ref = 40 °C (ISO VG reference),
    ΔT = T_ref − T_oil:
    coulomb_additive: G += s·12·ΔT N·m;  viscous_exponential: f_v ·= exp(s·0.025·ΔT);
    proportional: G, f_v ·= 1 + s·0.005·ΔT;  viscous_additive: f_v += s·250·ΔT N·m·s/rad.
gear_ripple — output angle, 96 cycles/rev; motor angle, 1 and 2 cycles per motor revolution:
    output_angle: torque on the output body s·300·[sin(96q+φ1) + 0.35 sin(192q+φ2) +
      0.15 sin(288q+φ3)] N·m (downstream of the transducer);
    output_kinematic: kinematic error in the twist, s·(300 N·m/k)·[sin(96q+φ1) +
      0.3 sin(192q+φ2)];
    motor_angle: kinematic error s·(250 N·m/k)·[sin(θ_m+φ4) + 0.4 sin(2θ_m+φ5)], θ_m = N·u;
    load_modulated: s·300·(0.25 + 0.75·|T|/T_r)·sin(96q+φ1) N·m on the output body.
torque_offset — on the torque reading: constant: s·300 N·m; ramp: s·400·t/t_end N·m;
    settling: s·350·(1 − e^(−t/15 s)) N·m.
time_delay — torque: the torque reading delayed by s·30 ms; load_cell: the load-cell reading
    delayed s·30 ms; encoder: q and qd delayed s·2 ms (a fieldbus cycle; 30 ms would shift
    the twist of a joint at 3000 r/min by 12 kN·m equivalent); torque_first_order: an extra
    first-order lag s·30 ms on the torque reading.
hysteresis — in the transmission, on the (backlash-free part of the) twist:
    bouc_wen_n1: T += s·k_h·x, ẋ = Δ̇ − β|Δ̇|x − γΔ̇|x|, β = γ = 1/(2Δ_y), Δ_y = 4e-5 rad,
      k_h = 300 N·m/Δ_y (loop half-height 300 N·m);
    bouc_wen_n2: same with n = 2 (β = γ = 1/(2Δ_y²));
    prandtl_ishlinskii: T += s·Σ w_i·stop_{r_i}(Δ), r = 1, 2, 4, 8 e-5 rad, w_i·r_i = 75 N·m;
    load_widening: T += s·4.0e4·|Δ|·λ, Dahl state λ̇ = Δ̇/ε·(1 − λ·sgn Δ̇), ε = 4e-5 rad
      (loop half-height ≈ 350 N·m at the rated twist, nothing at zero load).
backlash — dead zone of half-width b = s·2.5e-5 rad (k·b ≈ 340 N·m) in the twist:
    sharp: Δ_e = Δ ∓ b outside, 0 inside (damping in contact only);
    tanh: Δ_e = Δ − b·tanh(Δ/b);  sqrt: Δ_e = Δ − b·Δ/√(Δ² + b²);
    preload: a weak spring inside the gap: Δ_e = 0.1·Δ inside, Δ ∓ 0.9·b outside.
asymmetric_friction — coulomb: f_c·(1 ± s·0.1) for q̇ ≷ 0; viscous: f_v·(1 ± s·0.4);
    coulomb_viscous: both; one_sided: f_c·(1 + s·0.2) for q̇ > 0 only.
Out of the vocabulary:
periodic_disturbance — torque on the output body (hydraulic power pack through the loading
    shaft, not seen by the load cell): sine: s·300·sin(2π·0.37t+φ); two_tone: s·(200 sin(2π·0.37t)
    + 150 sin(2π·1.13t)); pulse: s·300·tanh(4·sin(2π·0.13t+φ)).
position_stiffness — k(q) = k·(1 + s·a(q)): cosine: a = 0.004·cos(q+φ); two_per_rev:
    a = 0.004·cos(2q+φ); linear: a = 0.006·q/(0.5 rad).
sensor_drift — load_cell_ramp: load-cell reading + s·300·t/60 s N·m; load_cell_walk: a random
    walk of sd s·250 N·m after 60 s (its own stream of (seed, run)); encoder_ramp: the output
    encoder reading (q and qd) drifts s·2.5e-5 rad per minute.
second_resonance — a load-side appendage (inertia s·r·I on a spring, natural frequency f,
    damping ζ) hanging on the output body, unmeasured: load_side_3hz: r = 1.0, 3 Hz, ζ = 0.02;
    load_side_11hz: r = 0.5, 11 Hz, ζ = 0.03; load_side_1hz: r = 1.5, 1.2 Hz, ζ = 0.05.

Limits: 0 ≤ s ≤ SCALE_MAX = 5; sample rate 1–4000 Hz (validated 10 Hz–1 kHz); encoder step
1e-5°–1°; temp_joint_c in [−10, 60] °C; scheme 3 periods 1–10.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field

import numba
import numpy as np
import pandas as pd
from scipy.signal import lfilter

RIG_NAME = "rig_r"
REDUCTION = 11000.0
SEED_IS_CAMPAIGN = True
SCALE_MAX = 5.0

EFFECT_FORMS: dict[str, tuple[str, ...]] = {
    "stribeck": ("exp1", "exp2", "lorentzian", "exp_half"),
    "load_dependent_friction": ("coulomb", "coulomb_viscous", "power_flow", "quadratic"),
    "temperature_friction": ("coulomb_additive", "viscous_exponential", "proportional",
                             "viscous_additive"),
    "gear_ripple": ("output_angle", "output_kinematic", "motor_angle", "load_modulated"),
    "torque_offset": ("constant", "ramp", "settling"),
    "time_delay": ("torque", "load_cell", "encoder", "torque_first_order"),
    "hysteresis": ("bouc_wen_n1", "bouc_wen_n2", "prandtl_ishlinskii", "load_widening"),
    "backlash": ("sharp", "tanh", "sqrt", "preload"),
    "asymmetric_friction": ("coulomb", "viscous", "coulomb_viscous", "one_sided"),
    "periodic_disturbance": ("sine", "two_tone", "pulse"),
    "position_stiffness": ("cosine", "two_per_rev", "linear"),
    "sensor_drift": ("load_cell_ramp", "load_cell_walk", "encoder_ramp"),
    "second_resonance": ("load_side_3hz", "load_side_11hz", "load_side_1hz"),
}

OUT_OF_VOCABULARY: tuple[str, ...] = ("periodic_disturbance", "position_stiffness",
                                      "sensor_drift", "second_resonance")

UNSTATED_VOCABULARY: dict[str, str] = {
    "torque_offset": "torque transducer zero offset (sd 30 N·m) with a slow thermal zero drift "
                     "(sd 8 N·m/min), not stated",
    "time_delay": "load-cell amplifier lags the torque amplifier by an extra 3–5 ms "
                  "first-order, not stated",
}

# --- constants -------------------------------------------------------------------------------
H0 = 2.0e-4                       # internal step [s]
T_RATED = 120e3                   # N·m
OMEGA_MAX = 3000.0 * 2 * math.pi / 60.0 / REDUCTION    # 0.02856 rad/s
K_NOM = 1.375e7
TWIST_RATED = T_RATED / K_NOM
FOURIER_PERIOD = 16.0
FOURIER_A = (0.6, -0.2, 0.35, -0.5, -0.25)
FOURIER_B = (0.5, 0.3, -0.4, 0.1, -0.06)
AMP_TAU = 1.6e-4                  # torque / load-cell amplifier poles (two) [s]
ADC_STEP = 400e3 / 65536.0        # N·m
QD_WINDOW = 0.010                 # s
QD_TAU = 0.005                    # s
UD_TAU = 0.002                    # s
FINE_COUNT = 2 * math.pi / 2 ** 24
MOTOR_COUNT = 2 * math.pi / 2 ** 20 / REDUCTION
KT = 2.0
TABLE3 = {"I": 6685.166, "mr_x": 20.779, "mr_y": -34.543, "f_v": 8683.272, "f_c": 2352.660}

# parameter vector layout
(P_I, P_MRX, P_MRY, P_FV, P_FC, P_SIG0, P_SIG1, P_K, P_C3, P_DR, P_D, P_JR, P_FCM, P_FVM,
 P_KP, P_KI, P_KPOS, P_TMAX, P_WD, P_ZD, P_GD, P_AD, P_ND, P_PHD, P_COIL, P_TAUOIL, P_TAUH1,
 P_TAUH2, P_TAMB, P_ETA, P_G, P_N) = range(32)
NP = 32

# effect slots: codes C[k] (0 = absent) and float parameters E
C_STR, C_LDF, C_TMP, C_RIP, C_HYS, C_BL, C_ASY, C_PER, C_POS, C_RES = range(10)
NC = 10
(E_STR_DF, E_STR_VS, E_LDF_M1, E_LDF_M2, E_TMP_C, E_TMP_REF, E_RIP_A, E_RIP_N, E_RIP_P1,
 E_RIP_P2, E_RIP_P3, E_RIP_P4, E_RIP_P5, E_HYS_K, E_HYS_DY, E_BL_B, E_ASY_C, E_ASY_V,
 E_PER_A1, E_PER_F1, E_PER_P1, E_PER_A2, E_PER_F2, E_PER_P2, E_POS_A, E_POS_P, E_RES_IB,
 E_RES_W, E_RES_Z) = range(29)
E_PI_R = 29     # 4 radii
E_PI_W = 33     # 4 weights
NE = 37

# state layout
(Y_Q, Y_V, Y_U, Y_W, Y_Z, Y_XI, Y_TL, Y_TLD, Y_XBW, Y_E2, Y_E2D, Y_TOIL, Y_TH, Y_LAM) = range(14)
NY = 14
# stored outputs per step
(O_Q, O_V, O_U, O_W, O_T, O_TL, O_F, O_TM, O_TOIL, O_TH) = range(10)
NO = 10


# --- the kernel ------------------------------------------------------------------------------

@numba.njit(cache=True)
def _rhs(t, y, ref, P, C, E, play, dy, aux):
    q = y[Y_Q]
    v = y[Y_V]
    u = y[Y_U]
    w = y[Y_W]
    N = P[P_N]
    # ---- transmission
    kin = 0.0
    kind = 0.0
    cr = C[C_RIP]
    if cr == 2:
        A = E[E_RIP_A]
        n = E[E_RIP_N]
        kin = A * (math.sin(n * q + E[E_RIP_P1]) + 0.3 * math.sin(2 * n * q + E[E_RIP_P2]))
        kind = A * n * v * (math.cos(n * q + E[E_RIP_P1])
                            + 0.6 * math.cos(2 * n * q + E[E_RIP_P2]))
    elif cr == 3:
        A = E[E_RIP_A]
        th = N * u
        kin = A * (math.sin(th + E[E_RIP_P4]) + 0.4 * math.sin(2 * th + E[E_RIP_P5]))
        kind = A * N * w * (math.cos(th + E[E_RIP_P4]) + 0.8 * math.cos(2 * th + E[E_RIP_P5]))
    d = u - q - kin
    dd = w - v - kind
    cb = C[C_BL]
    de = d
    dde = dd
    if cb != 0:
        b = E[E_BL_B]
        if cb == 1:
            if d > b:
                de = d - b
            elif d < -b:
                de = d + b
            else:
                de = 0.0
                dde = 0.0
        elif cb == 2:
            th = math.tanh(d / b)
            de = d - b * th
            dde = dd * th * th
        elif cb == 3:
            r = math.sqrt(d * d + b * b)
            de = d - b * d / r
            dde = dd * (1.0 - b * b * b / (r * r * r))
        else:
            rho = 0.1
            if d > b:
                de = d - (1.0 - rho) * b
            elif d < -b:
                de = d + (1.0 - rho) * b
            else:
                de = rho * d
                dde = rho * dd
    kq = P[P_K]
    cp = C[C_POS]
    if cp == 1:
        kq = kq * (1.0 + E[E_POS_A] * math.cos(q + E[E_POS_P]))
    elif cp == 2:
        kq = kq * (1.0 + E[E_POS_A] * math.cos(2.0 * q + E[E_POS_P]))
    elif cp == 3:
        kq = kq * (1.0 + E[E_POS_A] * q / 0.5)
    rr = de / P[P_DR]
    Tt = kq * de * (1.0 + P[P_C3] * rr * rr) + P[P_D] * dde
    ch = C[C_HYS]
    dx = 0.0
    dlam = 0.0
    if ch == 1 or ch == 2:
        x = y[Y_XBW]
        Dy = E[E_HYS_DY]
        Tt += E[E_HYS_K] * x
        if ch == 1:
            bg = 0.5 / Dy
            dx = dde - bg * abs(dde) * x - bg * dde * abs(x)
        else:
            bg = 0.5 / (Dy * Dy)
            dx = dde - bg * abs(dde) * abs(x) * x - bg * dde * x * x
    elif ch == 3:
        for i in range(4):
            ri = E[E_PI_R + i]
            p = play[i]
            lo = de - ri
            hi = de + ri
            if p < lo:
                p = lo
            elif p > hi:
                p = hi
            Tt += E[E_PI_W + i] * (de - p)
    elif ch == 4:
        lam = y[Y_LAM]
        Tt += E[E_HYS_K] * abs(de) * lam
        sg = 1.0 if dde > 0 else (-1.0 if dde < 0 else 0.0)
        dlam = dde / E[E_HYS_DY] * (1.0 - lam * sg)
    absT = abs(Tt)
    # ---- friction
    FC = P[P_FC]
    g = FC
    fv = P[P_FV]
    ca = C[C_ASY]
    if ca != 0:
        sv = 1.0 if v >= 0 else -1.0
        if ca == 1:
            g = g * (1.0 + E[E_ASY_C] * sv)
        elif ca == 2:
            fv = fv * (1.0 + E[E_ASY_V] * sv)
        elif ca == 3:
            g = g * (1.0 + E[E_ASY_C] * sv)
            fv = fv * (1.0 + E[E_ASY_V] * sv)
        elif v > 0:
            g = g * (1.0 + E[E_ASY_C])
    cl = C[C_LDF]
    if cl == 1:
        g += E[E_LDF_M1] * absT
    elif cl == 2:
        g += E[E_LDF_M1] * absT
        fv = fv * (1.0 + E[E_LDF_M2] * absT / 120e3)
    elif cl == 3:
        if Tt * v > 0:
            g += E[E_LDF_M1] * absT
        else:
            g += E[E_LDF_M2] * absT
    elif cl == 4:
        g += E[E_LDF_M1] * Tt * Tt / 120e3
    ct = C[C_TMP]
    if ct != 0:
        dT = E[E_TMP_REF] - y[Y_TOIL]
        c = E[E_TMP_C]
        if ct == 1:
            g += c * dT
        elif ct == 2:
            fv = fv * math.exp(c * dT)
        elif ct == 3:
            fac = max(1.0 + c * dT, 0.3)
            g = g * fac
            fv = fv * fac
        else:
            fv += c * dT
    cs = C[C_STR]
    if cs != 0:
        xv = abs(v) / E[E_STR_VS]
        if cs == 1:
            g += E[E_STR_DF] * math.exp(-xv)
        elif cs == 2:
            g += E[E_STR_DF] * math.exp(-xv * xv)
        elif cs == 3:
            g += E[E_STR_DF] / (1.0 + xv * xv)
        else:
            g += E[E_STR_DF] * math.exp(-math.sqrt(xv))
    g = max(g, 0.4 * FC)
    fv = max(fv, 0.2 * P[P_FV])
    z = y[Y_Z]
    dz = v - P[P_SIG0] * abs(v) * z / g
    F = P[P_SIG0] * z + P[P_SIG1] * dz + fv * v
    # ---- output body
    G = P[P_G] * (P[P_MRX] * math.sin(q) + P[P_MRY] * math.cos(q))
    tex = 0.0
    if cr == 1:
        A = E[E_RIP_A]
        n = E[E_RIP_N]
        tex += A * (math.sin(n * q + E[E_RIP_P1]) + 0.35 * math.sin(2 * n * q + E[E_RIP_P2])
                    + 0.15 * math.sin(3 * n * q + E[E_RIP_P3]))
    elif cr == 4:
        tex += E[E_RIP_A] * (0.25 + 0.75 * absT / 120e3) * math.sin(E[E_RIP_N] * q + E[E_RIP_P1])
    cpd = C[C_PER]
    if cpd == 1:
        tex += E[E_PER_A1] * math.sin(2 * math.pi * E[E_PER_F1] * t + E[E_PER_P1])
    elif cpd == 2:
        tex += E[E_PER_A1] * math.sin(2 * math.pi * E[E_PER_F1] * t + E[E_PER_P1])
        tex += E[E_PER_A2] * math.sin(2 * math.pi * E[E_PER_F2] * t + E[E_PER_P2])
    elif cpd == 3:
        tex += E[E_PER_A1] * math.tanh(4.0 * math.sin(2 * math.pi * E[E_PER_F1] * t
                                                      + E[E_PER_P1]))
    e2 = y[Y_E2]
    e2d = y[Y_E2D]
    w2 = E[E_RES_W]
    z2 = E[E_RES_Z]
    if C[C_RES] != 0:
        tex += E[E_RES_IB] * (w2 * w2 * e2 + 2.0 * z2 * w2 * e2d)
    tl = y[Y_TL]
    qdd = (Tt - tl - G - F + tex) / P[P_I]
    # ---- motor side
    uref = ref[0]
    wref = ref[1] + P[P_KPOS] * (uref - u)
    Tm = P[P_KP] * (wref - w) + y[Y_XI] + P[P_JR] * ref[2]
    dxi = P[P_KI] * (wref - w)
    TM = P[P_TMAX]
    if Tm > TM:
        Tm = TM
        if dxi > 0:
            dxi = 0.0
    elif Tm < -TM:
        Tm = -TM
        if dxi < 0:
            dxi = 0.0
    Fm = P[P_FCM] * math.tanh(w / 0.002) + P[P_FVM] * w
    wdot = (Tm - Tt - Fm) / P[P_JR]
    # ---- dynamometer
    tgt = P[P_GD] * ref[3] + P[P_AD] * math.sin(P[P_ND] * q + P[P_PHD])
    tld = y[Y_TLD]
    tldd = P[P_WD] * P[P_WD] * (tgt - tl) - 2.0 * P[P_ZD] * P[P_WD] * tld
    # ---- thermal
    Ploss = abs(F * v) + P[P_ETA] * abs(Tt * w)
    dTo = Ploss / P[P_COIL] - (y[Y_TOIL] - y[Y_TH]) / P[P_TAUOIL]
    dTh = (y[Y_TOIL] - y[Y_TH]) / P[P_TAUH1] - (y[Y_TH] - P[P_TAMB]) / P[P_TAUH2]
    dy[Y_Q] = v
    dy[Y_V] = qdd
    dy[Y_U] = w
    dy[Y_W] = wdot
    dy[Y_Z] = dz
    dy[Y_XI] = dxi
    dy[Y_TL] = tld
    dy[Y_TLD] = tldd
    dy[Y_XBW] = dx
    dy[Y_E2] = e2d
    dy[Y_E2D] = -w2 * w2 * e2 - 2.0 * z2 * w2 * e2d - qdd
    dy[Y_TOIL] = dTo
    dy[Y_TH] = dTh
    dy[Y_LAM] = dlam
    aux[0] = Tt
    aux[1] = F
    aux[2] = Tm
    aux[3] = de


@numba.njit(cache=True)
def _integrate(h, n_steps, refs, P, C, E, y0):
    out = np.empty((n_steps + 1, NO))
    y = y0.copy()
    yt = np.empty(NY)
    k1 = np.empty(NY)
    k2 = np.empty(NY)
    k3 = np.empty(NY)
    k4 = np.empty(NY)
    aux = np.empty(4)
    play = np.zeros(4)
    for i in range(n_steps + 1):
        t = i * h
        _rhs(t, y, refs[2 * i], P, C, E, play, k1, aux)
        out[i, O_Q] = y[Y_Q]
        out[i, O_V] = y[Y_V]
        out[i, O_U] = y[Y_U]
        out[i, O_W] = y[Y_W]
        out[i, O_T] = aux[0]
        out[i, O_TL] = y[Y_TL]
        out[i, O_F] = aux[1]
        out[i, O_TM] = aux[2]
        out[i, O_TOIL] = y[Y_TOIL]
        out[i, O_TH] = y[Y_TH]
        if i == n_steps:
            break
        for j in range(NY):
            yt[j] = y[j] + 0.5 * h * k1[j]
        _rhs(t + 0.5 * h, yt, refs[2 * i + 1], P, C, E, play, k2, aux)
        for j in range(NY):
            yt[j] = y[j] + 0.5 * h * k2[j]
        _rhs(t + 0.5 * h, yt, refs[2 * i + 1], P, C, E, play, k3, aux)
        for j in range(NY):
            yt[j] = y[j] + h * k3[j]
        _rhs(t + h, yt, refs[2 * i + 2], P, C, E, play, k4, aux)
        for j in range(NY):
            y[j] = y[j] + h / 6.0 * (k1[j] + 2.0 * k2[j] + 2.0 * k3[j] + k4[j])
        if C[C_HYS] == 3:
            _rhs(t + h, y, refs[2 * i + 2], P, C, E, play, k4, aux)
            de = aux[3]
            for m in range(4):
                ri = E[E_PI_R + m]
                if play[m] < de - ri:
                    play[m] = de - ri
                elif play[m] > de + ri:
                    play[m] = de + ri
    return out


# --- the public data classes -------------------------------------------------------------------

def _finite(name: str, v, lo: float, hi: float, lo_open: bool = False) -> float:
    if isinstance(v, bool) or not isinstance(v, (int, float, np.integer, np.floating)):
        raise ValueError(f"{name} must be a number, got {v!r}")  # noqa: TRY004 (the contract)
    x = float(v)
    if not math.isfinite(x):
        raise ValueError(f"{name} must be finite, got {v!r}")
    if (x <= lo if lo_open else x < lo) or x > hi:
        raise ValueError(f"{name} must be in {'(' if lo_open else '['}{lo}, {hi}], got {v!r}")
    return x


@dataclass
class SensorSpec:
    """What the rig's sensors are set to (stated in the run metadata)."""

    sample_rate_hz: float = 100.0
    encoder_res_deg: float = 0.01
    torque_noise: float = 150.0       # sd [N·m]
    torque_lag_s: float = 0.0         # a pure extra lag of the torque reading, stated
    load_noise: float = 100.0         # sd of the load cell [N·m]

    def __post_init__(self) -> None:
        self.validate()

    def validate(self) -> None:
        _finite("sample_rate_hz", self.sample_rate_hz, 1.0, 4000.0)
        _finite("encoder_res_deg", self.encoder_res_deg, 1e-5, 1.0)
        _finite("torque_noise", self.torque_noise, 0.0, 1e5)
        _finite("torque_lag_s", self.torque_lag_s, 0.0, 1.0)
        _finite("load_noise", self.load_noise, 0.0, 1e5)


@dataclass
class RigRun:
    samples: pd.DataFrame
    meta: dict
    truth: pd.DataFrame
    params: dict = field(default_factory=dict)


# --- machine and effects ------------------------------------------------------------------------

def _clipn(rng: np.random.Generator) -> float:
    return float(np.clip(rng.standard_normal(), -2.5, 2.5))


def _machine(seed: int, temp_c: float) -> tuple[np.ndarray, dict, dict, dict]:
    rng = np.random.default_rng([int(seed), 0x52494752])
    m = {
        "I": TABLE3["I"] * (1 + 0.02 * _clipn(rng)),
        "mr_x": TABLE3["mr_x"] * (1 + 0.03 * _clipn(rng)),
        "mr_y": TABLE3["mr_y"] * (1 + 0.03 * _clipn(rng)),
        "f_v": TABLE3["f_v"] * (1 + 0.03 * _clipn(rng)),
        "f_c": TABLE3["f_c"] * (1 + 0.03 * _clipn(rng)),
        "sigma0": 1.2e8 * (1 + 0.1 * _clipn(rng)),
        "sigma1": 5.4e5 * (1 + 0.1 * _clipn(rng)),
        "k": K_NOM * (1 + 0.03 * _clipn(rng)),
        "c3": 0.05 * (1 + 0.1 * _clipn(rng)),
        "D": 6.0e4 * (1 + 0.1 * _clipn(rng)),
        "dyno_gain": 1.0 + 0.003 * _clipn(rng),
        "dyno_ripple": 25.0 * (1 + 0.2 * _clipn(rng)),
        "dyno_phase": float(rng.uniform(0, 2 * math.pi)),
    }
    jr = 3 * 0.0125 * REDUCTION ** 2
    wc = 40.0
    m.update({"J_r": jr, "Fc_motor": 1500.0, "fv_motor": 2.0e4, "Kp": jr * wc,
              "Ki": jr * wc * wc / 4.0, "Kpos": wc / 4.0, "Tm_max": 2.2e5,
              "dyno_wn": 2 * math.pi * 4.0, "dyno_zeta": 0.8, "dyno_cycles_per_rad": 2 * 60.0,
              "C_oil": 4000.0, "tau_oil": 90.0, "tau_h1": 400.0, "tau_h2": 3600.0,
              "T_amb": float(temp_c), "eta_loss": 0.03, "g": 9.81, "N": REDUCTION,
              "twist_rated": TWIST_RATED})
    shares = 1.0 + 0.01 * np.clip(rng.standard_normal(3), -2.5, 2.5)
    shares = shares * 3.0 / shares.sum()
    unstated = {
        "torque_zero_nm": float(np.clip(30.0 * rng.standard_normal(), -75, 75)),
        "torque_zero_drift_nm_per_min": 8.0 * _clipn(rng),
        "torque_gain_error": 5e-4 * _clipn(rng),
        "load_gain_error": 5e-4 * _clipn(rng),
        "load_cell_extra_lag_s": float(rng.uniform(3e-3, 5e-3)),
        "temp_offset_c": 0.2 * _clipn(rng),
        "current_shares": [float(s) for s in shares],
    }
    phases = {f"ph{i}": float(rng.uniform(0, 2 * math.pi)) for i in range(1, 10)}
    P = np.zeros(NP)
    P[P_I], P[P_MRX], P[P_MRY] = m["I"], m["mr_x"], m["mr_y"]
    P[P_FV], P[P_FC], P[P_SIG0], P[P_SIG1] = m["f_v"], m["f_c"], m["sigma0"], m["sigma1"]
    P[P_K], P[P_C3], P[P_DR], P[P_D] = m["k"], m["c3"], TWIST_RATED, m["D"]
    P[P_JR], P[P_FCM], P[P_FVM] = jr, m["Fc_motor"], m["fv_motor"]
    P[P_KP], P[P_KI], P[P_KPOS], P[P_TMAX] = m["Kp"], m["Ki"], m["Kpos"], m["Tm_max"]
    P[P_WD], P[P_ZD], P[P_GD] = m["dyno_wn"], m["dyno_zeta"], m["dyno_gain"]
    P[P_AD], P[P_ND], P[P_PHD] = m["dyno_ripple"], m["dyno_cycles_per_rad"], m["dyno_phase"]
    P[P_COIL], P[P_TAUOIL], P[P_TAUH1], P[P_TAUH2] = (m["C_oil"], m["tau_oil"], m["tau_h1"],
                                                      m["tau_h2"])
    P[P_TAMB], P[P_ETA], P[P_G], P[P_N] = m["T_amb"], m["eta_loss"], m["g"], REDUCTION
    return P, m, unstated, phases


def _check_effects(effects) -> dict[str, tuple[str, float]]:
    if effects is None:
        return {}
    if not isinstance(effects, dict):
        raise ValueError(  # noqa: TRY004 (the contract: bad arguments raise ValueError)
            f"effects must be a dict {{name: {{'form', 'scale'}}}}, got {effects!r}")
    out: dict[str, tuple[str, float]] = {}
    for name, spec in effects.items():
        if name not in EFFECT_FORMS:
            raise ValueError(f"unknown effect {name!r}; known: {sorted(EFFECT_FORMS)}")
        if not isinstance(spec, dict) or set(spec) != {"form", "scale"}:
            raise ValueError(f"effect {name!r} must be {{'form': ..., 'scale': ...}}, got {spec!r}")
        form = spec["form"]
        if form not in EFFECT_FORMS[name]:
            raise ValueError(f"unknown form {form!r} of effect {name!r}; known: "
                             f"{list(EFFECT_FORMS[name])}")
        s = _finite(f"scale of {name!r}", spec["scale"], 0.0, SCALE_MAX)
        if s > 0.0:
            out[name] = (form, s)
    return out


def _effect_arrays(eff: dict[str, tuple[str, float]], m: dict, ph: dict) -> tuple[np.ndarray,
                                                                                  np.ndarray]:
    C = np.zeros(NC, dtype=np.int64)
    E = np.zeros(NE)
    E[E_STR_VS] = 1.0
    E[E_HYS_DY] = 1.0
    E[E_BL_B] = 1.0
    E[E_RES_W] = 1.0

    def code(name: str) -> int:
        return EFFECT_FORMS[name].index(eff[name][0]) + 1

    if "stribeck" in eff:
        s = eff["stribeck"][1]
        C[C_STR] = code("stribeck")
        E[E_STR_DF] = s * 0.25 * m["f_c"]
        E[E_STR_VS] = 0.008
    if "load_dependent_friction" in eff:
        f, s = eff["load_dependent_friction"]
        C[C_LDF] = code("load_dependent_friction")
        E[E_LDF_M1], E[E_LDF_M2] = {"coulomb": (0.0035, 0.0), "coulomb_viscous": (0.002, 0.5),
                                    "power_flow": (0.004, 0.0015),
                                    "quadratic": (0.004, 0.0)}[f]
        E[E_LDF_M1] *= s
        E[E_LDF_M2] *= s
    if "temperature_friction" in eff:
        f, s = eff["temperature_friction"]
        C[C_TMP] = code("temperature_friction")
        E[E_TMP_C] = s * {"coulomb_additive": 12.0, "viscous_exponential": 0.025,
                          "proportional": 0.005, "viscous_additive": 250.0}[f]
        E[E_TMP_REF] = 40.0
    E[E_RIP_N] = 96.0
    E[E_RIP_P1], E[E_RIP_P2], E[E_RIP_P3] = ph["ph1"], ph["ph2"], ph["ph3"]
    E[E_RIP_P4], E[E_RIP_P5] = ph["ph4"], ph["ph5"]
    if "gear_ripple" in eff:
        f, s = eff["gear_ripple"]
        C[C_RIP] = code("gear_ripple")
        E[E_RIP_A] = s * {"output_angle": 300.0, "output_kinematic": 300.0 / m["k"],
                          "motor_angle": 250.0 / m["k"], "load_modulated": 300.0}[f]
    if "hysteresis" in eff:
        f, s = eff["hysteresis"]
        C[C_HYS] = code("hysteresis")
        if f in ("bouc_wen_n1", "bouc_wen_n2"):
            E[E_HYS_DY] = 4e-5
            E[E_HYS_K] = s * 300.0 / 4e-5
        elif f == "prandtl_ishlinskii":
            for i, r in enumerate((1e-5, 2e-5, 4e-5, 8e-5)):
                E[E_PI_R + i] = r
                E[E_PI_W + i] = s * 75.0 / r
        else:
            E[E_HYS_DY] = 4e-5
            E[E_HYS_K] = s * 4.0e4
    if "backlash" in eff:
        s = eff["backlash"][1]
        C[C_BL] = code("backlash")
        E[E_BL_B] = s * 2.5e-5
    if "asymmetric_friction" in eff:
        f, s = eff["asymmetric_friction"]
        C[C_ASY] = code("asymmetric_friction")
        E[E_ASY_C] = s * (0.2 if f == "one_sided" else 0.1)
        E[E_ASY_V] = s * 0.4
    if "periodic_disturbance" in eff:
        f, s = eff["periodic_disturbance"]
        C[C_PER] = code("periodic_disturbance")
        if f == "sine":
            E[E_PER_A1], E[E_PER_F1] = s * 300.0, 0.37
        elif f == "two_tone":
            E[E_PER_A1], E[E_PER_F1] = s * 200.0, 0.37
            E[E_PER_A2], E[E_PER_F2] = s * 150.0, 1.13
        else:
            E[E_PER_A1], E[E_PER_F1] = s * 300.0, 0.13
        E[E_PER_P1], E[E_PER_P2] = ph["ph6"], ph["ph7"]
    if "position_stiffness" in eff:
        f, s = eff["position_stiffness"]
        C[C_POS] = code("position_stiffness")
        E[E_POS_A] = s * (0.006 if f == "linear" else 0.004)
        E[E_POS_P] = ph["ph8"]
    if "second_resonance" in eff:
        f, s = eff["second_resonance"]
        C[C_RES] = code("second_resonance")
        r, fr, zr = {"load_side_3hz": (1.0, 3.0, 0.02), "load_side_11hz": (0.5, 11.0, 0.03),
                     "load_side_1hz": (1.5, 1.2, 0.05)}[f]
        E[E_RES_IB] = s * r * m["I"]
        E[E_RES_W] = 2 * math.pi * fr
        E[E_RES_Z] = zr
    return C, E


# --- schemes -------------------------------------------------------------------------------------

def _cos_ramp(t: np.ndarray, t0: float, dur: float) -> tuple[np.ndarray, np.ndarray]:
    """0 → 1 over [t0, t0+dur] with a half-cosine; returns value and derivative."""
    x = np.clip((t - t0) / dur, 0.0, 1.0)
    val = 0.5 * (1 - np.cos(np.pi * x))
    der = np.where((x > 0) & (x < 1), 0.5 * np.pi / dur * np.sin(np.pi * x), 0.0)
    return val, der


def _duration(scheme: int, periods: int) -> float:
    return {1: 63.0, 2: 58.0}.get(scheme, periods * FOURIER_PERIOD)


def _fourier_coeffs() -> tuple[np.ndarray, np.ndarray, float]:
    a = np.array(FOURIER_A)
    b = np.array(FOURIER_B)
    wf = 2 * np.pi / FOURIER_PERIOD
    tt = np.linspace(0.0, FOURIER_PERIOD, 20001)
    l_ = np.arange(1, 6)[:, None]
    v = (a[:, None] * np.cos(wf * l_ * tt) + b[:, None] * np.sin(wf * l_ * tt)).sum(0)
    gain = 0.9 * OMEGA_MAX / np.abs(v).max()
    return a * gain, b * gain, wf


def _references(scheme: int, omega: float, direction: int, t: np.ndarray) -> np.ndarray:
    """u_ref, u̇_ref, ü_ref, torque_cmd at the times t."""
    ref = np.zeros((len(t), 4))
    if scheme in (1, 2):
        up, dup = _cos_ramp(t, 2.0, 1.5)
        dn, ddn = _cos_ramp(t, 59.5 if scheme == 1 else 54.5, 1.5)
        w = direction * omega * (up - dn)
        wd = direction * omega * (dup - ddn)
        # u_ref: the exact integral of the two half-cosine ramps
        def integ(t0, dur):
            x = np.clip((t - t0) / dur, 0.0, 1.0)
            inside = 0.5 * dur * (x - np.sin(np.pi * x) / np.pi)
            return np.where(t > t0 + dur, 0.5 * dur + (t - t0 - dur), inside)
        tdn = 59.5 if scheme == 1 else 54.5
        ref[:, 0] = direction * omega * (integ(2.0, 1.5) - integ(tdn, 1.5))
        ref[:, 1] = w
        ref[:, 2] = wd
        if scheme == 1:
            ref[:, 3] = T_RATED * (np.clip((t - 5.0) / 25.0, 0, 1)
                                   - np.clip((t - 33.0) / 25.0, 0, 1))
        else:
            cmd = np.zeros_like(t)
            for k in range(12):
                cmd += 10e3 * np.clip(t - (5.0 + 3.0 * k), 0, 1)
            cmd -= T_RATED * np.clip((t - 41.0) / 12.0, 0, 1)
            ref[:, 3] = cmd
    else:
        a, b, wf = _fourier_coeffs()
        q = np.zeros_like(t)
        qd = np.zeros_like(t)
        qdd = np.zeros_like(t)
        for l_ in range(1, 6):
            wl = wf * l_
            s, c = np.sin(wl * t), np.cos(wl * t)
            q += a[l_ - 1] / wl * s - b[l_ - 1] / wl * c + b[l_ - 1] / wl
            qd += a[l_ - 1] * c + b[l_ - 1] * s
            qdd += -a[l_ - 1] * wl * s + b[l_ - 1] * wl * c
        ref[:, 0] = direction * q
        ref[:, 1] = direction * qd
        ref[:, 2] = direction * qdd
    return ref


def _phases(scheme: int, t: np.ndarray) -> np.ndarray:
    ph = np.full(len(t), "idle", dtype=object)
    if scheme == 3:
        ph[:] = "excite"
    elif scheme == 1:
        ph[(t >= 5.0) & (t < 30.0)] = "load"
        ph[(t >= 30.0) & (t < 33.0)] = "hold"
        ph[(t >= 33.0) & (t < 58.0)] = "unload"
    else:
        rel = t - 5.0
        stepping = (rel >= 0) & (t < 41.0)
        ph[stepping & (np.mod(rel, 3.0) < 1.0)] = "load"
        ph[stepping & (np.mod(rel, 3.0) >= 1.0)] = "hold"
        ph[(t >= 41.0) & (t < 53.0)] = "unload"
    return ph


# --- sensor helpers ------------------------------------------------------------------------------

def _lag1(x: np.ndarray, tau: float, h: float) -> np.ndarray:
    """Exact first-order lag on the internal grid, started at steady state."""
    if tau <= 0.0:
        return x
    a = math.exp(-h / tau)
    y, _ = lfilter([1.0 - a], [1.0, -a], x, zi=[a * x[0]])
    return y


def _delay(x: np.ndarray, d: float, h: float) -> np.ndarray:
    """x(t − d) on the internal grid, linear interpolation, held at x[0] before the start."""
    if d <= 0.0:
        return x
    j = d / h
    J = math.floor(j)
    fr = j - J
    n = len(x)
    idx0 = np.clip(np.arange(n) - J, 0, n - 1)
    idx1 = np.clip(np.arange(n) - J - 1, 0, n - 1)
    return (1.0 - fr) * x[idx0] + fr * x[idx1]


def _quant(x: np.ndarray, step: float) -> np.ndarray:
    return np.round(x / step) * step


# --- the run -----------------------------------------------------------------------------------

def simulate_run(scheme: int, motor_speed_rpm: float | None, direction: int, temp_joint_c: float,
                 effects: dict[str, dict] | None = None, *, sensors: SensorSpec | None = None,
                 periods: int = 3, seed: int, run: int) -> RigRun:
    """Simulate one run of the bench (see the module's data sheet)."""
    if isinstance(scheme, bool) or not isinstance(scheme, (int, np.integer)) \
            or int(scheme) not in (1, 2, 3):
        raise ValueError(f"scheme must be 1, 2 or 3, got {scheme!r}")
    scheme = int(scheme)
    if scheme == 3:
        if motor_speed_rpm is not None:
            raise ValueError("motor_speed_rpm must be None for scheme 3 (the Fourier trajectory)")
        speed = None
    else:
        if motor_speed_rpm is None:
            raise ValueError(f"motor_speed_rpm is required for scheme {scheme}")
        speed = _finite("motor_speed_rpm", motor_speed_rpm, 0.0, 3000.0, lo_open=True)
    if isinstance(direction, bool) or not isinstance(direction, (int, np.integer)) \
            or int(direction) not in (1, -1):
        raise ValueError(f"direction must be +1 or -1, got {direction!r}")
    direction = int(direction)
    temp = _finite("temp_joint_c", temp_joint_c, -10.0, 60.0)
    if isinstance(periods, bool) or not isinstance(periods, (int, np.integer)) \
            or not 1 <= int(periods) <= 10:
        raise ValueError(f"periods must be an integer in [1, 10], got {periods!r}")
    periods = int(periods)
    for nm, val in (("seed", seed), ("run", run)):
        if isinstance(val, bool) or not isinstance(val, (int, np.integer)) or int(val) < 0:
            raise ValueError(f"{nm} must be an integer >= 0, got {val!r}")
    if sensors is None:
        sensors = SensorSpec()
    if not isinstance(sensors, SensorSpec):
        raise ValueError(f"sensors must be a SensorSpec, got {sensors!r}")  # noqa: TRY004
    sensors.validate()
    eff = _check_effects(effects)

    fs = float(sensors.sample_rate_hz)
    msteps = math.ceil(1.0 / (fs * H0) - 1e-9)
    h = 1.0 / (fs * msteps)
    dur = _duration(scheme, periods)
    n_samp = round(dur * fs) + 1
    n_steps = (n_samp - 1) * msteps
    omega = 0.0 if speed is None else speed * 2 * math.pi / 60.0 / REDUCTION

    P, m, unstated, ph = _machine(int(seed), temp)
    C, E = _effect_arrays(eff, m, ph)
    t_half = np.arange(2 * n_steps + 1) * (0.5 * h)
    refs = _references(scheme, omega, direction, t_half)
    y0 = np.zeros(NY)
    G0 = m["g"] * m["mr_y"]
    y0[Y_Z] = -G0 / m["sigma0"]
    y0[Y_TOIL] = temp
    y0[Y_TH] = temp
    out = _integrate(h, n_steps, refs, P, C, E, y0)

    ti = np.arange(n_steps + 1) * h
    t_end = ti[-1]
    sidx = np.arange(n_samp) * msteps
    ts = np.arange(n_samp) / fs

    # ---- noise, in a fixed order independent of the effects
    rng = np.random.default_rng([int(seed), int(run), 0x4E4F495345])
    n_torque = rng.standard_normal(n_samp)
    n_load = rng.standard_normal(n_samp)
    n_cur = rng.standard_normal((3, n_samp))
    n_spd = rng.standard_normal((3, n_samp))
    n_temp = rng.standard_normal(n_samp)

    q_true, v_true = out[:, O_Q], out[:, O_V]
    u_true, w_true = out[:, O_U], out[:, O_W]
    T_true, tl_true = out[:, O_T], out[:, O_TL]

    def form(name: str) -> tuple[str | None, float]:
        return eff.get(name, (None, 0.0))

    # ---- torque transducer
    tq = (1.0 + unstated["torque_gain_error"]) * T_true + unstated["torque_zero_nm"] \
        + unstated["torque_zero_drift_nm_per_min"] * ti / 60.0
    f_off, s_off = form("torque_offset")
    if f_off == "constant":
        tq = tq + s_off * 300.0
    elif f_off == "ramp":
        tq = tq + s_off * 400.0 * ti / t_end
    elif f_off == "settling":
        tq = tq + s_off * 350.0 * (1.0 - np.exp(-ti / 15.0))
    f_del, s_del = form("time_delay")
    d_torque = sensors.torque_lag_s + (s_del * 0.030 if f_del == "torque" else 0.0)
    tq = _delay(tq, d_torque, h)
    if f_del == "torque_first_order":
        tq = _lag1(tq, s_del * 0.030, h)
    tq = _lag1(_lag1(tq, AMP_TAU, h), AMP_TAU, h)
    torque_s = _quant(tq[sidx] + sensors.torque_noise * n_torque, ADC_STEP)

    # ---- load cell
    ld = (1.0 + unstated["load_gain_error"]) * tl_true
    f_dr, s_dr = form("sensor_drift")
    if f_dr == "load_cell_ramp":
        ld = ld + s_dr * 300.0 * ti / 60.0
    elif f_dr == "load_cell_walk":
        wrng = np.random.default_rng([int(seed), int(run), 0x57414C4B])
        steps = wrng.standard_normal(n_samp)
        walk = np.concatenate([[0.0], np.cumsum(steps[1:])]) * math.sqrt(1.0 / fs / 60.0)
        ld = ld + s_dr * 250.0 * np.interp(ti, ts, walk)
    ld = _lag1(ld, unstated["load_cell_extra_lag_s"], h)
    if f_del == "load_cell":
        ld = _delay(ld, s_del * 0.030, h)
    ld = _lag1(_lag1(ld, AMP_TAU, h), AMP_TAU, h)
    load_s = _quant(ld[sidx] + sensors.load_noise * n_load, ADC_STEP)

    # ---- output encoder and its velocity
    qe = q_true
    if f_dr == "encoder_ramp":
        qe = qe + s_dr * 2.5e-5 * ti / 60.0
    if f_del == "encoder":
        qe = _delay(qe, s_del * 0.002, h)
    res = math.radians(sensors.encoder_res_deg)
    q_s = _quant(qe[sidx], res)
    qf = _quant(qe, FINE_COUNT)
    nw = max(1, round(QD_WINDOW / h))
    qf_prev = np.concatenate([np.full(nw, qf[0]), qf[:-nw]])
    qd_raw = (qf - qf_prev) / (nw * h)
    qd_s = _lag1(qd_raw, QD_TAU, h)[sidx]
    qd_lag = 0.5 * nw * h + QD_TAU

    # ---- motor side
    u_s = _quant(u_true[sidx], MOTOR_COUNT)
    ud_s = _lag1(w_true, UD_TAU, h)[sidx]
    Tm = out[:, O_TM]
    shares = unstated["current_shares"]
    cur = [shares[k] * Tm[sidx] / (3 * REDUCTION * KT) + 0.01 * n_cur[k] for k in range(3)]
    spd = [REDUCTION * ud_s + 0.05 * n_spd[k] for k in range(3)]
    temp_m0 = temp + 8.0
    a_m = math.exp(-h / 600.0)
    temps_m = []
    for k in range(3):
        i_k = shares[k] * Tm / (3 * REDUCTION * KT)
        heat = 0.8 * i_k * i_k * 0.06   # K above start at equilibrium
        rise, _ = lfilter([1 - a_m], [1, -a_m], heat, zi=[0.0])
        temps_m.append(temp_m0 + rise[sidx])
    temp_s = np.round((out[sidx, O_TH] + unstated["temp_offset_c"] + 0.03 * n_temp) / 0.1) * 0.1

    cmd_s = refs[2 * sidx, 3]
    samples = pd.DataFrame({
        "t": ts, "q": q_s, "qd": qd_s, "u": u_s, "ud": ud_s, "torsion": q_s - u_s,
        "torque": torque_s, "torque_load": load_s, "torque_cmd": cmd_s,
        "i_m1": cur[0], "i_m2": cur[1], "i_m3": cur[2],
        "w_m1": spd[0], "w_m2": spd[1], "w_m3": spd[2],
        "temp_m1": temps_m[0], "temp_m2": temps_m[1], "temp_m3": temps_m[2],
        "temp_joint": temp_s, "phase": _phases(scheme, ts),
    })
    truth = pd.DataFrame({
        "t": ts, "q": q_true[sidx], "qd": v_true[sidx], "u": u_true[sidx], "ud": w_true[sidx],
        "twist": u_true[sidx] - q_true[sidx], "torque": T_true[sidx],
        "torque_load": tl_true[sidx], "torque_cmd": cmd_s, "friction": out[sidx, O_F],
        "torque_motor": Tm[sidx], "temp_oil": out[sidx, O_TOIL], "temp_housing": out[sidx, O_TH],
    })
    meta = {
        "scheme": scheme,
        "motor_speed_rpm": speed,
        "direction": direction,
        "reduction": REDUCTION,
        "rig": RIG_NAME,
        "source": "emulator",
        "sample_rate_hz": fs,
        "started_at": f"2026-03-{1 + int(seed) % 28:02d}T{8 + int(run) % 12:02d}:00:00Z",
        "notes": f"{RIG_NAME} validation rig, scheme {scheme}, joint at {temp:.1f} °C",
        "sensors": {
            "q": {"resolution": res, "noise_sd": 0.0, "lag_s": 0.0},
            "qd": {"resolution": FINE_COUNT / (nw * h), "noise_sd": 0.0, "lag_s": qd_lag},
            "u": {"resolution": MOTOR_COUNT, "noise_sd": 0.0, "lag_s": 0.0},
            "ud": {"noise_sd": 0.0, "lag_s": UD_TAU},
            "torque": {"resolution": ADC_STEP, "noise_sd": float(sensors.torque_noise),
                       "lag_s": float(sensors.torque_lag_s) + 2 * AMP_TAU},
            "torque_load": {"resolution": ADC_STEP, "noise_sd": float(sensors.load_noise),
                            "lag_s": 2 * AMP_TAU},
            "temp_joint": {"resolution": 0.1, "noise_sd": 0.03, "lag_s": 0.0},
        },
    }
    if scheme == 3:
        meta["periods"] = periods
    params = {
        "machine": m,
        "effects": {k: {"form": f, "scale": s} for k, (f, s) in eff.items()},
        "effect_phases": ph,
        "unstated": unstated,
        "sensors": asdict(sensors),
        "internal_step_s": h,
        "steps_per_sample": msteps,
        "duration_s": float(ts[-1]),
        "temp_joint_c": temp,
        "seed": int(seed),
        "run": int(run),
    }
    return RigRun(samples=samples, meta=meta, truth=truth, params=params)
