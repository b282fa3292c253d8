"""Validation rig D: an independently written emulator of the J4 heavy-joint test rig.

Data sheet
==========

Purpose
-------
Rig D produces runs of the J4 joint test platform (schemes 1-3) with known injected
effects, to score the sim-to-real diagnosis blind.  It shares no code with the project's
simulators: its own integrator, friction law, transmission, drive loop and sensors.
SI units throughout; angles in rad referred to the output unless said otherwise.

Mechanics (two-inertia model, output side + motor side)
-------------------------------------------------------
Symbols: ``q`` output angle, ``u`` motor angle / N (N = 11000), twist ``Δ = u − q``,
``T`` the transmitted torque (what the joint torque transducer between gearbox and
output carries), ``τ_L`` the dynamometer torque on the output.

* Output side:  ``I·q̈ = T − τ_L − g·(mr_x·sin q + mr_y·cos q) − F_f − τ_d``
  where ``F_f`` is the output-side friction (LuGre, below) and ``τ_d`` any
  output-side disturbance torque injected by an effect (gear-mesh ripple, ...).
* Transmission (nominal): linear spring and damper ``T = k·Δ + D·Δ̇``.
* Motor side (three motors lumped, referred to the output):
  ``J_r·ü = N·Σ_k k_t,k·i_k − T − F_m``,
  ``F_m = F_cm·tanh(u̇/ε_m) + f_vm·u̇ + μ_m·|T|·tanh(u̇/ε_m)`` (motor-side and gear losses,
  upstream of the torque transducer; they show in the currents only).
* Output friction, LuGre (Canudas de Wit et al.): bristle state ``z``,
  ``ż = q̇ − σ0·|q̇|·z/g(q̇)``,  ``F_f = σ0·z + σ1·ż + f_v·q̇``, nominal ``g = f_c``;
  ``σ0 = f_c / 1e-5 rad`` (presliding ~1e-5 rad), ``σ1 = 0.6·sqrt(σ0·I)``.
  ``z`` is advanced with its exact exponential solution over a step (stable at any speed).

Nominal values (each campaign draws its own within the ranges; uniform)
-----------------------------------------------------------------------
==================  =======================  =========================
I                   6685 kg·m² ×[0.95,1.05]  output + dynamometer inertia
mr_x, mr_y          20.8, −34.5 kg·m ×[0.9,1.1]  gravity term (g = 9.81 m/s²)
f_c, f_v            2353 N·m, 8683 N·m·s/rad ×[0.9,1.1]
k                   1.37e7 N·m/rad ×[0.9,1.1]  (≈0.5° twist at 120 kN·m)
D                   2·0.04·sqrt(k·I)           transmission damping
J_r                 9.1e4 kg·m² ×[0.95,1.05]   3 rotors × 2.5e-4 kg·m² × N²
F_cm, f_vm, μ_m     1200 N·m, 4000 N·m·s/rad ×[0.9,1.1], 0.04 ; ε_m = 2e-4 rad/s
k_t,k               1.25 N·m/A ×[0.985,1.015] per motor; current share ×[0.98,1.02]
T_amb               [18, 26] °C
dynamometer lag     first order, τ ∈ [0.2, 0.35] s; set-point error an
                    Ornstein-Uhlenbeck process (sd 500 N·m, 2 s), clipped at ±1.9 kN·m
==================  =======================  =========================

Drive (S120-like cascade, output units)
--------------------------------------
Velocity PI on the motor speed (``K_p = 4e6 N·m·s/rad``, ``K_i = 4e7 N·m/rad``, anti-windup
by clamping), a position P loop on the motor encoder in scheme 3 (``K_pos = 8 s⁻¹``),
per-motor current loops as first-order lags (1 ms), current limit 10 A per motor.
The current command is split equally between the three motors.

Thermal
-------
Gearbox temperature ``C·Ṫ_j = P_loss − (T_j − T_amb)/R``, ``C = 4e5 J/K``, ``R = 0.02 K/W``,
``P_loss = |F_f·q̇| + |F_m·u̇|``.  ``T_j(0)`` is the run's ``temp_joint_c``.

Schemes
-------
1. Idle 2 s (motor accelerates over 0.5–1.5 s to the commanded speed), load ramp
   0 → 120 kN·m in 48 s, unload ramp in 48 s, idle 2 s: 100 s at constant motor speed.
2. Idle 2 s, twelve steps of +10 kN·m (ramp 2 s "load", hold 2 s "hold"), unload
   120 → 0 in 8 s, idle 2 s: 60 s at constant motor speed.
3. No load.  Idle 2 s, ``periods`` periods of a fifth-order Fourier trajectory (period 20 s,
   peak speed 0.027 rad/s, zero speed and acceleration at the period boundaries), idle 2 s.

The dynamometer always loads positively (paper convention, ``τ_L ≥ 0``); ``direction``
signs the motion, so ``direction = −1`` runs are back-driven under load.

Integration
-----------
Semi-implicit (symplectic) Euler at a fixed internal step ``dt = 1/(f_s·m)``,
``m = ceil(4000/f_s)`` (dt ≤ 0.25 ms), compiled with numba.  Samples are latched every
``m`` steps (zero-order hold of the DAQ).

Sensors
-------
* ``q``: output encoder, quantised at ``encoder_res_deg`` (zeroed at 0 at the start).
* ``qd``: software estimate, backward difference of the quantised ``q`` over
  ``max(1, round(0.1·f_s))`` samples (0.1 s window).
* ``u``: motor encoder, 17 bit per motor revolution (resolution 2π/2^17/N rad);
  ``ud`` its backward difference over one sample.
* ``torque``: transducer, first-order anti-alias filter 2 ms, transport lag
  ``torque_lag_s``, white noise ``torque_noise``, 16-bit ADC over ±200 kN·m (6.1 N·m).
* ``torque_load``: dynamometer load cell, white noise ``load_noise``.
* ``temp_joint``: PT100, quantised at 0.1 °C.
* ``i_m1..3``: noise sd ``current_noise`` A; ``w_m1..3``: motor speeds, noise sd ``speed_noise`` rad/s.

Effects (``effects = {name: {"form": f, "scale": s}}``; all sizes below are for s = 1 and
scale linearly with s; s = 0 is exactly the nominal run)
--------------------------------------------------------------------------------------
stribeck (added to g(v) of LuGre; ΔF = 0.6·f_c·φ(v)):
  exponential φ = exp(−|v|/0.004); gaussian φ = exp(−(v/0.004)²);
  lorentzian φ = 1/(1 + (v/0.003)²); sqrt φ = exp(−sqrt(|v|/0.002))  (v in rad/s).
temperature_friction (d = (30 °C − T_j)/20):
  viscous_arrhenius f_v·(1 + s·(exp(0.05·(30 − T_j)) − 1));
  coulomb_linear f_c + s·25 N·m/K·(30 − T_j);
  both_quadratic f_v·(1 + s·G), f_c·(1 + 0.5·s·G), G = 0.4·d + 0.15·d².
load_dependent_friction (T = transmitted torque):
  coulomb_linear f_c + s·0.015·|T|;  coulomb_and_viscous f_c + s·0.008·|T| and
  f_v·(1 + s·|T|/120 kN·m);  power_flow f_c + s·0.02·|T| when driving (T·q̇ > 0),
  f_c + s·0.005·|T| when back-driven.
asymmetric_friction (σ = sign of q̇):
  coulomb_ratio f_c·(1 + 0.2·s·σ);  viscous_slope f_v·(1 + 0.6·s·σ);
  negative_side f_c and f_v ×(1 + 0.3·s) for q̇ < 0 only.
gear_ripple:
  output_mesh  output torque 600·s·(sin(36q + φ1) + 0.35·sin(72q + φ2)) N·m;
  motor_stage_te transmission error e = 4e-5·s·(sin(200u + φ3) + 0.3·sin(400u + φ4)) rad,
  T = k·(Δ − e) (2 and 4 cycles per revolution of the first-stage shaft, ratio 110);
  load_modulated output torque s·(150 + 0.008·|T|)·sin(36q + φ1) N·m.
backlash (half-gap b = 1.5e-4·s rad in the spring law):
  sharp dead zone, damping only in contact; smooth: dead zone with hyperbolic
  corners of width ε = 0.5·b; preload_closing: sharp with b_eff = b/(1 + |T|/20 kN·m).
hysteresis:
  bouc_wen_n1 / bouc_wen_n2: T = k·((1 − a)·Δ + a·x) + D·Δ̇, a = 0.1·s,
  ẋ = Δ̇ − β|Δ̇||x|^(n−1)x − γΔ̇|x|^n, β = γ = 0.5/x_y^n, x_y = 2.5e-3 rad;
  dahl: T = k·Δ + D·Δ̇ + s·h, ḣ = σ_d·Δ̇·(1 − h·sgn(Δ̇)/h_m), h_m = 1500 N·m,
  σ_d = 3e7 N·m/rad (saturates within ~5e-5 rad of a twist reversal: a ±1.5 kN·m loop).
torque_offset (added to the torque reading):
  constant 800·s N·m; linear_drift 12·s·t N·m; exp_drift 1500·s·(1 − exp(−t/30 s)) N·m.
time_delay (of the torque reading): transport 0.04·s s; first_order lag τ = 0.06·s s;
  second_order two cascaded lags of τ = 0.03·s s.

Out of vocabulary (OUT_OF_VOCABULARY):
  periodic_disturbance: pump_sine 500·s·sin(2π·0.7·t + φ5) N·m on the output;
    two_tone 350·s·sin(2π·0.7·t + φ5) + 200·s·sin(2π·2.1·t + φ6).
  position_stiffness: cosine k·(1 + 0.15·s·cos(q + φ7)); linear k·(1 + 0.1·s·q/rad).
  bending_crosstalk (hydraulic bending moment M_b = 1.6·τ_L,set into the torque gauge):
    static +0.008·s·M_b; pulsating +s·(300 + 0.002·M_b)·sin(2π·7.3·t + φ8).
  second_resonance: a fraction 0.2·s of I moves to the loading shaft, coupled by a spring
    tuned to shaft_3hz 3 Hz or shaft_8hz 8 Hz (ζ = 0.02); the dynamometer acts on the shaft.
  encoder_eccentricity: output encoder reads q + 5e-5·s·sin(q + φ9) (once_per_rev) or
    q + 5e-5·s·sin(2q + φ9) (twice_per_rev).
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import numba
import numpy as np
import pandas as pd

SEED_IS_CAMPAIGN = True
REDUCTION = 11000.0

EFFECT_FORMS: dict[str, tuple[str, ...]] = {
    "stribeck": ("exponential", "gaussian", "lorentzian", "sqrt"),
    "temperature_friction": ("viscous_arrhenius", "coulomb_linear", "both_quadratic"),
    "load_dependent_friction": ("coulomb_linear", "coulomb_and_viscous", "power_flow"),
    "asymmetric_friction": ("coulomb_ratio", "viscous_slope", "negative_side"),
    "gear_ripple": ("output_mesh", "motor_stage_te", "load_modulated"),
    "backlash": ("sharp", "smooth", "preload_closing"),
    "hysteresis": ("bouc_wen_n1", "bouc_wen_n2", "dahl"),
    "torque_offset": ("constant", "linear_drift", "exp_drift"),
    "time_delay": ("transport", "first_order", "second_order"),
    "periodic_disturbance": ("pump_sine", "two_tone"),
    "position_stiffness": ("cosine", "linear"),
    "bending_crosstalk": ("static", "pulsating"),
    "second_resonance": ("shaft_3hz", "shaft_8hz"),
    "encoder_eccentricity": ("once_per_rev", "twice_per_rev"),
}
OUT_OF_VOCABULARY: tuple[str, ...] = (
    "periodic_disturbance", "position_stiffness", "bending_crosstalk",
    "second_resonance", "encoder_eccentricity",
)
_FAMILY = {name: i for i, name in enumerate(EFFECT_FORMS)}
# family index = position in EFFECT_FORMS; the integration loop reads modes[i]/sc[i] with
# 0 stribeck, 1 temperature_friction, 2 load_dependent_friction, 3 asymmetric_friction,
# 4 gear_ripple, 5 backlash, 6 hysteresis, 8 time_delay (lags), 9 periodic_disturbance,
# 10 position_stiffness, 12 second_resonance; the sensor-side families are applied after it:
_OFFSET, _DELAY, _XTALK, _ECC = 7, 8, 11, 13

_T_REF_C = 30.0
_FULL_LOAD = 120000.0
_ADC_RES = 400000.0 / 65536.0           # N·m, 16 bit over ±200 kN·m
_AA_TAU = 0.002                          # s, anti-alias filter of the torque transducer
_U_RES = 2.0 * math.pi / 2**17 / REDUCTION
_TEMP_RES = 0.1
_F_INT_MIN = 4000.0                      # Hz, minimum internal integration rate


@dataclass(frozen=True)
class SensorSpec:
    """What the rig's sensors resolve (data-sheet figures, SI units)."""

    sample_rate_hz: float = 100.0       # logging rate, 10 Hz – 1 kHz
    encoder_res_deg: float = 0.001      # output encoder step (deg)
    torque_noise: float = 150.0         # white noise sd on the torque reading (N·m)
    torque_lag_s: float = 0.0           # transport lag of the torque reading (s)
    load_noise: float = 250.0           # white noise sd on the load cell (N·m)
    current_noise: float = 0.02         # white noise sd on each motor current (A)
    speed_noise: float = 0.05           # white noise sd on each motor speed (rad/s, motor side)


@dataclass
class RigRun:
    """One simulated run: logged samples, metadata and noise-free truth."""

    samples: pd.DataFrame
    meta: dict
    truth: pd.DataFrame


# ----------------------------------------------------------------------------- parameters
# layout of the campaign parameter vector P
_P_NAMES = ("I", "mrx", "mry", "fc", "fv", "k", "D", "Jr", "Fcm", "fvm", "mum",
            "kt1", "kt2", "kt3", "sh1", "sh2", "sh3", "Tamb", "tau_dyn",
            "ph1", "ph2", "ph3", "ph4", "ph5", "ph6", "ph7", "ph8", "ph9")
_PI = {n: i for i, n in enumerate(_P_NAMES)}


def _campaign_params(seed: int) -> np.ndarray:
    """Draw the rig parameters of a campaign (fixed order, independent of effects)."""
    rng = np.random.default_rng([int(seed), 0xD0D0])
    u = lambda lo, hi: float(rng.uniform(lo, hi))  # noqa: E731
    p = np.zeros(len(_P_NAMES))
    p[_PI["I"]] = 6685.0 * u(0.95, 1.05)
    p[_PI["mrx"]] = 20.8 * u(0.9, 1.1)
    p[_PI["mry"]] = -34.5 * u(0.9, 1.1)
    p[_PI["fc"]] = 2353.0 * u(0.9, 1.1)
    p[_PI["fv"]] = 8683.0 * u(0.9, 1.1)
    p[_PI["k"]] = 1.37e7 * u(0.9, 1.1)
    p[_PI["D"]] = 2.0 * 0.04 * math.sqrt(p[_PI["k"]] * p[_PI["I"]])
    p[_PI["Jr"]] = 9.1e4 * u(0.95, 1.05)
    p[_PI["Fcm"]] = 1200.0 * u(0.9, 1.1)
    p[_PI["fvm"]] = 4000.0 * u(0.9, 1.1)
    p[_PI["mum"]] = 0.04
    for j in (1, 2, 3):
        p[_PI[f"kt{j}"]] = 1.25 * u(0.985, 1.015)
    for j in (1, 2, 3):
        p[_PI[f"sh{j}"]] = u(0.98, 1.02)
    p[_PI["Tamb"]] = u(18.0, 26.0)
    p[_PI["tau_dyn"]] = u(0.2, 0.35)
    for j in range(1, 10):
        p[_PI[f"ph{j}"]] = u(0.0, 2.0 * math.pi)
    return p


def _parse_effects(effects: dict[str, dict]) -> tuple[np.ndarray, np.ndarray]:
    """Validate effects; return per-family form codes (1-based, 0 = off) and scales."""
    modes = np.zeros(len(EFFECT_FORMS), dtype=np.int64)
    scales = np.zeros(len(EFFECT_FORMS))
    for name, spec in (effects or {}).items():
        if name not in EFFECT_FORMS:
            raise ValueError(f"unknown effect {name!r}; known: {sorted(EFFECT_FORMS)}")
        if not isinstance(spec, dict) or "form" not in spec:
            raise ValueError(f"effect {name!r} needs a dict with 'form' (and 'scale')")
        form = spec["form"]
        if form not in EFFECT_FORMS[name]:
            raise ValueError(f"unknown form {form!r} of effect {name!r}; known: {EFFECT_FORMS[name]}")
        s = float(spec.get("scale", 1.0))
        if not math.isfinite(s):
            raise ValueError(f"effect {name!r}: scale must be finite, got {s!r}")
        if s == 0.0:
            continue
        i = _FAMILY[name]
        modes[i] = EFFECT_FORMS[name].index(form) + 1
        scales[i] = s
    return modes, scales


# ----------------------------------------------------------------------------- schedules
def _fourier_coeffs() -> tuple[np.ndarray, np.ndarray, float]:
    """Fifth-order Fourier velocity coefficients with zero speed/acceleration at t = 0."""
    a = np.array([0.5, -0.2, 0.3, -0.4, -0.2])
    b = np.array([0.6, 0.3, -0.4, 0.1, -0.08])
    wf = 2.0 * math.pi / 20.0
    tt = np.linspace(0.0, 20.0, 4001)
    l = np.arange(1, 6)[:, None]
    v = (a[:, None] * np.cos(l * wf * tt) + b[:, None] * np.sin(l * wf * tt)).sum(axis=0)
    g = 0.027 / np.abs(v).max()
    return a * g, b * g, wf


def _schedule(scheme: int, speed_rpm: float | None, direction: int, periods: int,
              t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Reference motor speed/position (output units), load set point and phase code at t.

    Phase codes: 0 idle, 1 load, 2 hold, 3 unload, 4 excite.
    """
    ud = np.zeros_like(t)
    uref = np.zeros_like(t)
    load = np.zeros_like(t)
    phase = np.zeros(t.shape, dtype=np.int64)
    if scheme in (1, 2):
        w = direction * speed_rpm * 2.0 * math.pi / 60.0 / REDUCTION
        ramp = np.clip((t - 0.5) / 1.0, 0.0, 1.0)
        ud = w * ramp
        # position of the ramped speed profile (only used for the record; K_pos = 0)
        uref = w * np.where(t < 0.5, 0.0, np.where(t < 1.5, 0.5 * (t - 0.5) ** 2, t - 1.0))
        if scheme == 1:
            tl = t - 2.0
            load = np.where((tl >= 0) & (tl < 48.0), _FULL_LOAD * tl / 48.0,
                            np.where((tl >= 48.0) & (tl < 96.0), _FULL_LOAD * (96.0 - tl) / 48.0, 0.0))
            phase = np.where((tl >= 0) & (tl < 48.0), 1, np.where((tl >= 48.0) & (tl < 96.0), 3, 0))
        else:
            tl = t - 2.0
            step = np.floor(tl / 4.0)
            within = tl - 4.0 * step
            in_steps = (tl >= 0) & (tl < 48.0)
            lvl = 10000.0 * (step + np.clip(within / 2.0, 0.0, 1.0))
            tu = tl - 48.0
            load = np.where(in_steps, lvl, np.where((tu >= 0) & (tu < 8.0), _FULL_LOAD * (1.0 - tu / 8.0), 0.0))
            phase = np.where(in_steps, np.where(within < 2.0, 1, 2), np.where((tu >= 0) & (tu < 8.0), 3, 0))
    else:
        a, b, wf = _fourier_coeffs()
        te = np.clip(t - 2.0, 0.0, periods * 20.0)
        active = (t >= 2.0) & (t < 2.0 + periods * 20.0)
        for l in range(1, 6):
            ud = ud + np.where(active, a[l - 1] * np.cos(l * wf * te) + b[l - 1] * np.sin(l * wf * te), 0.0)
            uref = uref + (a[l - 1] * np.sin(l * wf * te) - b[l - 1] * np.cos(l * wf * te) + b[l - 1]) / (l * wf)
        ud = direction * ud
        uref = direction * uref
        phase = np.where(active, 4, 0)
    return ud, uref, load, np.asarray(phase).astype(np.int64)


def _duration(scheme: int, periods: int) -> float:
    return {1: 100.0, 2: 60.0}.get(scheme, 4.0 + 20.0 * periods)


# ----------------------------------------------------------------------------- integrator
@numba.njit(cache=True)
def _integrate(P, modes, sc, dt, m_sub, n_samp, ud_ref, u_ref, load_set, dyn_err, kpos,
               temp0, out, tf_int):
    """Semi-implicit Euler integration of the rig; latches states every m_sub steps.

    out columns: q, qd, u, ud, T, tauL, Tj, i1, i2, i3, z.  tf_int[j]: filtered torque
    reading (anti-alias + effect lags) at time j·dt (length n_samp·m_sub + 1).
    """
    N = 11000.0
    I, mrx, mry, fc0, fv0, k0, D = P[0], P[1], P[2], P[3], P[4], P[5], P[6]
    Jr, Fcm, fvm, mum = P[7], P[8], P[9], P[10]
    kt1, kt2, kt3, sh1, sh2, sh3, Tamb, tau_dyn = P[11], P[12], P[13], P[14], P[15], P[16], P[17], P[18]
    ph1, ph2, ph3, ph4, ph5, ph6, ph7 = P[19], P[20], P[21], P[22], P[23], P[24], P[25]
    sigma0 = fc0 / 1e-5
    Kp, Ki = 4.0e6, 4.0e7
    kt_nom = 1.25
    i_max = 10.0
    a_i = 1.0 - math.exp(-dt / 0.001)
    a_dyn = 1.0 - math.exp(-dt / tau_dyn)
    a_aa = 1.0 - math.exp(-dt / 0.002)
    C_th, R_th = 4.0e5, 0.02
    eps_m = 2.0e-4

    # second resonance: split inertia
    I1 = I
    I2 = 0.0
    k2 = 0.0
    c2 = 0.0
    if modes[12] > 0:
        frac = min(0.2 * abs(sc[12]), 0.8)
        I2 = frac * I
        I1 = I - I2
        f2 = 3.0 if modes[12] == 1 else 8.0
        k2 = I2 * (2.0 * math.pi * f2) ** 2
        c2 = 2.0 * 0.02 * math.sqrt(k2 * I2)
    sigma1 = 0.6 * math.sqrt(sigma0 * I1)

    grav0 = 9.81 * mry
    q = 0.0
    qd = 0.0
    u = grav0 / k0
    ud = 0.0
    q2 = 0.0
    qd2 = 0.0
    z = 0.0
    integ = grav0
    i_share = grav0 / (3.0 * N * kt_nom)
    i1 = i_share * sh1
    i2 = i_share * sh2
    i3 = i_share * sh3
    tauL = 0.0
    Tj = temp0
    T = grav0
    xh = 0.0          # Bouc-Wen state (rad)
    hd = 0.0          # Dahl state (N·m)
    f_aa = grav0
    f_l1 = grav0
    f_l2 = grav0
    tf_int[0] = grav0
    tau1 = 0.0
    if modes[8] == 2:
        tau1 = 0.06 * abs(sc[8])
    elif modes[8] == 3:
        tau1 = 0.03 * abs(sc[8])
    a_l = 1.0
    if tau1 > 0.0:
        a_l = 1.0 - math.exp(-dt / tau1)

    n_steps = n_samp * m_sub
    for j in range(n_steps):
        t = j * dt
        if j % m_sub == 0:
            r = j // m_sub
            out[r, 0] = q
            out[r, 1] = qd
            out[r, 2] = u
            out[r, 3] = ud
            out[r, 4] = T
            out[r, 5] = tauL
            out[r, 6] = Tj
            out[r, 7] = i1
            out[r, 8] = i2
            out[r, 9] = i3
            out[r, 10] = z

        # ---------------- transmission torque
        k = k0
        if modes[10] == 1:
            k = k0 * max(1.0 + 0.15 * sc[10] * math.cos(q + ph7), 0.2)
        elif modes[10] == 2:
            k = k0 * max(1.0 + 0.1 * sc[10] * q, 0.2)
        dl = u - q
        dld = ud - qd
        if modes[4] == 2:
            th = 100.0 * u
            e = 4e-5 * sc[4] * (math.sin(2.0 * th + ph3) + 0.3 * math.sin(4.0 * th + ph4))
            ed = 4e-5 * sc[4] * (2.0 * math.cos(2.0 * th + ph3) + 1.2 * math.cos(4.0 * th + ph4)) * 100.0 * ud
            dl = dl - e
            dld = dld - ed
        slope = 1.0
        if modes[5] > 0:
            b = 1.5e-4 * abs(sc[5])
            if modes[5] == 3:
                b = b / (1.0 + abs(T) / 20000.0)
            if modes[5] == 1 or modes[5] == 3:
                if dl > b:
                    dl = dl - b
                elif dl < -b:
                    dl = dl + b
                else:
                    dl = 0.0
                    slope = 0.0
            else:
                ep = 0.5 * b
                sp = math.sqrt((dl - b) ** 2 + ep * ep)
                sm = math.sqrt((dl + b) ** 2 + ep * ep)
                slope = 0.5 * (1.0 + (dl - b) / sp) + 0.5 * (1.0 - (dl + b) / sm)
                dl = 0.5 * ((dl - b) + sp) + 0.5 * ((dl + b) - sm)
            dld = dld * slope
        if modes[6] == 1 or modes[6] == 2:
            a_h = min(0.1 * sc[6], 0.95)
            Tn = k * ((1.0 - a_h) * dl + a_h * xh) + D * dld
        elif modes[6] == 3:
            Tn = k * dl + D * dld + sc[6] * hd
        else:
            Tn = k * dl + D * dld
        T = Tn

        # ---------------- output friction (LuGre)
        v = qd
        fc = fc0
        fv = fv0
        if modes[1] == 1:
            fv = fv * max(1.0 + sc[1] * (math.exp(0.05 * (30.0 - Tj)) - 1.0), 0.05)
        elif modes[1] == 2:
            fc = max(fc + sc[1] * 25.0 * (30.0 - Tj), 0.05 * fc0)
        elif modes[1] == 3:
            d = (30.0 - Tj) / 20.0
            G = 0.4 * d + 0.15 * d * d
            fv = fv * max(1.0 + sc[1] * G, 0.05)
            fc = fc * max(1.0 + 0.5 * sc[1] * G, 0.05)
        if modes[2] == 1:
            fc = fc + sc[2] * 0.015 * abs(T)
        elif modes[2] == 2:
            fc = fc + sc[2] * 0.008 * abs(T)
            fv = fv * max(1.0 + sc[2] * abs(T) / 120000.0, 0.05)
        elif modes[2] == 3:
            if T * v > 0.0:
                fc = fc + sc[2] * 0.02 * abs(T)
            else:
                fc = fc + sc[2] * 0.005 * abs(T)
        sgn = 1.0 if v >= 0.0 else -1.0
        if modes[3] == 1:
            fc = fc * max(1.0 + 0.2 * sc[3] * sgn, 0.05)
        elif modes[3] == 2:
            fv = fv * max(1.0 + 0.6 * sc[3] * sgn, 0.05)
        elif modes[3] == 3:
            if v < 0.0:
                fc = fc * max(1.0 + 0.3 * sc[3], 0.05)
                fv = fv * max(1.0 + 0.3 * sc[3], 0.05)
        g = fc
        if modes[0] > 0:
            av = abs(v)
            if modes[0] == 1:
                phi = math.exp(-av / 0.004)
            elif modes[0] == 2:
                phi = math.exp(-(av / 0.004) ** 2)
            elif modes[0] == 3:
                phi = 1.0 / (1.0 + (av / 0.003) ** 2)
            else:
                phi = math.exp(-math.sqrt(av / 0.002))
            g = g + sc[0] * 0.6 * fc0 * phi
        g = max(g, 1.0)
        z_old = z
        if v != 0.0:
            zss = g / sigma0 * sgn
            z = zss + (z - zss) * math.exp(-sigma0 * abs(v) * dt / g)
        zd = (z - z_old) / dt
        Ff = sigma0 * z + sigma1 * zd + fv * v

        # ---------------- output-side disturbances
        tdist = 0.0
        if modes[4] == 1:
            tdist = 600.0 * sc[4] * (math.sin(36.0 * q + ph1) + 0.35 * math.sin(72.0 * q + ph2))
        elif modes[4] == 3:
            tdist = sc[4] * (150.0 + 0.008 * abs(T)) * math.sin(36.0 * q + ph1)
        if modes[9] == 1:
            tdist = tdist + 500.0 * sc[9] * math.sin(2.0 * math.pi * 0.7 * t + ph5)
        elif modes[9] == 2:
            tdist = tdist + sc[9] * (350.0 * math.sin(2.0 * math.pi * 0.7 * t + ph5)
                                     + 200.0 * math.sin(2.0 * math.pi * 2.1 * t + ph6))
        grav = 9.81 * (mrx * math.sin(q) + mry * math.cos(q))

        # ---------------- dynamometer
        tauL = tauL + (load_set[j] + dyn_err[j] - tauL) * a_dyn

        # ---------------- drive
        ev = ud_ref[j] + kpos * (u_ref[j] - u) - ud
        tcmd = Kp * ev + integ
        icmd = tcmd / (3.0 * N * kt_nom)
        if icmd > i_max:
            icmd = i_max
        elif icmd < -i_max:
            icmd = -i_max
        else:
            integ = integ + Ki * ev * dt
        i1 = i1 + (icmd * sh1 - i1) * a_i
        i2 = i2 + (icmd * sh2 - i2) * a_i
        i3 = i3 + (icmd * sh3 - i3) * a_i
        tm = N * (kt1 * i1 + kt2 * i2 + kt3 * i3)
        th_m = math.tanh(ud / eps_m)
        Fm = Fcm * th_m + fvm * ud + mum * abs(T) * th_m

        # ---------------- accelerations and semi-implicit update
        if I2 > 0.0:
            Fs = k2 * (q - q2) + c2 * (qd - qd2)
            qdd = (T - Fs - grav - Ff - tdist) / I1
            qdd2 = (Fs - tauL) / I2
            qd2 = qd2 + qdd2 * dt
            q2 = q2 + qd2 * dt
        else:
            qdd = (T - tauL - grav - Ff - tdist) / I1
        udd = (tm - T - Fm) / Jr
        qd = qd + qdd * dt
        ud = ud + udd * dt
        q = q + qd * dt
        u = u + ud * dt

        # ---------------- hysteresis states (driven by the new twist rate)
        if modes[6] == 1 or modes[6] == 2:
            dr = (ud - qd) * slope
            xy = 2.5e-3
            if modes[6] == 1:
                bb = 0.5 / xy
                xh = xh + (dr - bb * abs(dr) * xh - bb * dr * abs(xh)) * dt
            else:
                bb = 0.5 / (xy * xy)
                xh = xh + (dr - bb * abs(dr) * abs(xh) * xh - bb * dr * xh * xh) * dt
        elif modes[6] == 3:
            # scale-1 Dahl state (h_m = 1500 N·m, σ_d = 3e7 N·m/rad); the torque uses s·hd
            dr = (ud - qd) * slope
            if dr != 0.0:
                tgt = 1500.0 if dr > 0.0 else -1500.0
                hd = tgt + (hd - tgt) * math.exp(-3.0e7 * abs(dr) * dt / 1500.0)

        # ---------------- thermal
        Tj = Tj + ((abs(Ff * qd) + abs(Fm * ud)) - (Tj - Tamb) / R_th) / C_th * dt

        # ---------------- torque transducer filters
        f_aa = f_aa + (T - f_aa) * a_aa
        if modes[8] == 2:
            f_l1 = f_l1 + (f_aa - f_l1) * a_l
            tf_int[j + 1] = f_l1
        elif modes[8] == 3:
            f_l1 = f_l1 + (f_aa - f_l1) * a_l
            f_l2 = f_l2 + (f_l1 - f_l2) * a_l
            tf_int[j + 1] = f_l2
        else:
            tf_int[j + 1] = f_aa
    return out


# ----------------------------------------------------------------------------- public API
_PHASES = np.array(["idle", "load", "hold", "unload", "excite"], dtype=object)


def simulate_run(scheme: int, motor_speed_rpm: float | None, direction: int, temp_joint_c: float,
                 effects: dict[str, dict], *, seed: int, sensors: SensorSpec, periods: int = 3,
                 run: int = 0) -> RigRun:
    """Simulate one run of rig D.

    ``seed`` names the campaign (rig parameters), ``run`` keys the run's own noise.
    Returns samples at ``sensors.sample_rate_hz``, metadata and the noise-free truth.
    """
    if scheme not in (1, 2, 3):
        raise ValueError(f"scheme must be 1, 2 or 3, got {scheme!r}")
    if direction not in (1, -1):
        raise ValueError(f"direction must be +1 or -1, got {direction!r}")
    if scheme in (1, 2):
        if motor_speed_rpm is None or not motor_speed_rpm > 0:
            raise ValueError("schemes 1 and 2 need a positive motor_speed_rpm")
        motor_speed_rpm = float(motor_speed_rpm)
    else:
        motor_speed_rpm = None
        if int(periods) < 1:
            raise ValueError("periods must be >= 1")
    fs = float(sensors.sample_rate_hz)
    if not (1.0 <= fs <= 10000.0):
        raise ValueError(f"sample_rate_hz out of range: {fs}")
    modes, scales = _parse_effects(effects)

    P = _campaign_params(seed)
    duration = _duration(scheme, int(periods))
    n = int(round(duration * fs))
    m_sub = int(math.ceil(_F_INT_MIN / fs))
    dt = 1.0 / (fs * m_sub)
    t_int = np.arange(n * m_sub) * dt
    t = np.arange(n) / fs

    ud_ref, u_ref, load_set, _ = _schedule(scheme, motor_speed_rpm, direction, int(periods), t_int)
    _, _, load_set_s, phase_s = _schedule(scheme, motor_speed_rpm, direction, int(periods), t)
    kpos = 8.0 if scheme == 3 else 0.0

    # run noise: drawn in a fixed order, independent of the effects and of nothing else
    rng = np.random.default_rng([int(seed), int(run), 0xD1])
    n_ou = int(math.ceil(duration / 0.01)) + 2
    w = rng.standard_normal(n_ou)
    ou = np.empty(n_ou)
    a = math.exp(-0.01 / 2.0)
    ou[0] = 500.0 * w[0]
    for i in range(1, n_ou):
        ou[i] = a * ou[i - 1] + 500.0 * math.sqrt(1.0 - a * a) * w[i]
    ou = np.clip(ou, -1900.0, 1900.0)
    # no set-point error while the dynamometer is idle at zero set point in scheme 3
    dyn_err = np.interp(t_int, np.arange(n_ou) * 0.01, ou)
    if scheme == 3:
        dyn_err = dyn_err * 0.05
    e_torque = rng.standard_normal(n)
    e_load = rng.standard_normal(n)
    e_cur = rng.standard_normal((n, 3))
    e_spd = rng.standard_normal((n, 3))

    out = np.zeros((n, 11))
    tf_int = np.zeros(n * m_sub + 1)
    _integrate(P, modes, scales, dt, m_sub, n, ud_ref, u_ref, load_set, dyn_err, kpos,
               float(temp_joint_c), out, tf_int)
    q, qd, u, ud, T, tauL, Tj = (out[:, c] for c in range(7))
    cur = out[:, 7:10]

    # ---- torque reading (noise-free part)
    delay = float(sensors.torque_lag_s)
    if modes[_DELAY] == 1:
        delay += 0.04 * abs(scales[_DELAY])
    if delay > 0.0:
        t_f = np.arange(n * m_sub + 1) * dt
        tq_read = np.interp(t - delay, t_f, tf_int, left=tf_int[0])
    else:
        tq_read = tf_int[np.arange(n) * m_sub].copy()
    s_off = scales[_OFFSET]
    if modes[_OFFSET] == 1:
        tq_read = tq_read + 800.0 * s_off
    elif modes[_OFFSET] == 2:
        tq_read = tq_read + 12.0 * s_off * t
    elif modes[_OFFSET] == 3:
        tq_read = tq_read + 1500.0 * s_off * (1.0 - np.exp(-t / 30.0))
    m_b = 1.6 * load_set_s
    if modes[_XTALK] == 1:
        tq_read = tq_read + 0.008 * scales[_XTALK] * m_b
    elif modes[_XTALK] == 2:
        tq_read = tq_read + scales[_XTALK] * (300.0 + 0.002 * m_b) * np.sin(
            2.0 * math.pi * 7.3 * t + P[_PI["ph8"]])
    torque_meas = np.round((tq_read + sensors.torque_noise * e_torque) / _ADC_RES) * _ADC_RES

    # ---- encoders
    q_seen = q.copy()
    if modes[_ECC] == 1:
        q_seen = q_seen + 5e-5 * scales[_ECC] * np.sin(q + P[_PI["ph9"]])
    elif modes[_ECC] == 2:
        q_seen = q_seen + 5e-5 * scales[_ECC] * np.sin(2.0 * q + P[_PI["ph9"]])
    res_q = math.radians(float(sensors.encoder_res_deg))
    q_meas = np.round(q_seen / res_q) * res_q
    win = max(1, int(round(0.1 * fs)))
    qd_meas = np.zeros(n)
    if n > 1:
        idx = np.arange(n)
        back = np.maximum(idx - win, 0)
        span = (idx - back) / fs
        qd_meas[1:] = (q_meas[1:] - q_meas[back[1:]]) / span[1:]
    u_meas = np.round(u / _U_RES) * _U_RES
    ud_meas = np.zeros(n)
    if n > 1:
        ud_meas[1:] = np.diff(u_meas) * fs

    samples = pd.DataFrame({
        "t": t,
        "q": q_meas,
        "qd": qd_meas,
        "u": u_meas,
        "ud": ud_meas,
        "torque": torque_meas,
        "torque_load": tauL + sensors.load_noise * e_load,
        "temp_joint": np.round(Tj / _TEMP_RES) * _TEMP_RES,
        "phase": _PHASES[phase_s],
        "i_m1": cur[:, 0] + sensors.current_noise * e_cur[:, 0],
        "i_m2": cur[:, 1] + sensors.current_noise * e_cur[:, 1],
        "i_m3": cur[:, 2] + sensors.current_noise * e_cur[:, 2],
        "w_m1": ud * REDUCTION + sensors.speed_noise * e_spd[:, 0],
        "w_m2": ud * REDUCTION + sensors.speed_noise * e_spd[:, 1],
        "w_m3": ud * REDUCTION + sensors.speed_noise * e_spd[:, 2],
    })
    truth = pd.DataFrame({
        "t": t, "q": q, "qd": qd, "u": u, "ud": ud, "twist": u - q,
        "torque": tq_read, "torque_load": tauL, "torque_joint": T, "temp_joint": Tj,
        "torque_load_set": load_set_s,
    })
    meta = {
        "scheme": int(scheme),
        "motor_speed_rpm": motor_speed_rpm,
        "direction": int(direction),
        "reduction": 11000,
        "rig": "validation-rig-D",
        "source": "emulator",
        "sample_rate_hz": fs,
        "duration_s": n / fs,
        "temp_joint_c": float(temp_joint_c),
        "sensors": {
            "q": {"resolution": res_q},
            "qd": {"method": "backward difference of q", "window_s": win / fs},
            "u": {"resolution": _U_RES},
            "ud": {"method": "backward difference of u", "window_s": 1.0 / fs},
            "torque": {"noise_sd": float(sensors.torque_noise),
                       "lag_s": float(sensors.torque_lag_s) + _AA_TAU,
                       "resolution": _ADC_RES},
            "torque_load": {"noise_sd": float(sensors.load_noise)},
            "temp_joint": {"resolution": _TEMP_RES},
            "i_m": {"noise_sd": float(sensors.current_noise)},
            "w_m": {"noise_sd": float(sensors.speed_noise)},
        },
        "spec": asdict(sensors),
    }
    if scheme == 3:
        meta["periods"] = int(periods)
    return RigRun(samples=samples, meta=meta, truth=truth)
