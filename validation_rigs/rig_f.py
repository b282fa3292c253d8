"""Validation rig F: an independent emulator of the CMOR J4 joint test platform.

DATA SHEET (everything needed to rebuild the rig; SI units, angles output-referred unless said)
==============================================================================================

Purpose: produce runs of schemes 1-3 (see ``simulate_run``) with known injected effects, to
score a sim-to-real diagnosis blind. Nothing here is shared with the project's own emulator.

1. Drive train (three-mass, two compliant stages)
-------------------------------------------------
Motor side (three servo motors lumped, angle u = motor angle / N, N = 11000) -> stage 1
(precision reducer, ratio 110, compliance k1, damping c1) -> intermediate shaft (angle p,
inertia J_p, output-referred; it turns N2 = 100 times per output revolution) -> stage 2
(differential planetary, compliance k2, damping c2) -> joint output (angle q, inertia I) ->
torque transducer -> output bearings -> loading shaft, load cell, dynamometer.

  stage deflections   d1 = u - p - e_m(u),        d2 = p - q - e_o(q)   (e_*: kinematic error)
  twist               Delta = u - q = d1 + d2 + e_m + e_o  (the twist channel sees both stages)
  stage 1 torque      T1 = k1 * B(d1) + c1 * d1'              (B: backlash law, identity nominal)
  stage 2 torque      T  = k2 * d2 + c2 * d2' + H              (H: hysteretic torque, 0 nominal)
  T is the transmitted joint torque (what the torque transducer measures).

  motor               J_u * u''  = tau_m - T1 - F_m(u')
  intermediate        J_p * p''  = T1 - T
  output + dyn        (I + J_d) * q'' = T - tau_d - tau_r - g (mr_x sin q + mr_y cos q) - F(q', z) - tau_x
  load cell torque    tau_L = tau_d + tau_r + J_d * q''   (so I q'' = T - tau_L - gravity - F)

  nominal values (each campaign draws every one as value * (1 + U(-0.08, 0.08)) from seed):
  I = 6685 kg m^2, J_d = 400 kg m^2 (dynamometer + reducer, output-referred),
  J_p = 2000 kg m^2, J_m = 2.2e-4 kg m^2 per motor -> J_u = 3 J_m N^2 = 7.99e4 kg m^2,
  k1 = 3.0e7 N m/rad, k2 = 2.6e7 N m/rad (series k = 1.39e7: 0.49 deg twist at 120 kN m),
  c1 = 6.0e4 N m s/rad, c2 = 5.0e4 N m s/rad, g = 9.81 m/s^2, mr_x = 20.8 kg m, mr_y = -34.5 kg m.
  Motor-side drag F_m(w) = F_mc * w / sqrt(w^2 + (1e-4 rad/s)^2) + b_m * w,
  F_mc = 2500 N m, b_m = 3.0e4 N m s/rad (output-referred).

2. Output bearing friction: generalized Maxwell-slip, 4 LuGre-type elements
--------------------------------------------------------------------------
  z_i' = v - |v| * z_i / zmax_i,   zmax_i = w_i * L / kz_i,   v = q'
  F = sum_i (kz_i z_i + sz_i z_i') + V * v
  weights w = (0.4, 0.3, 0.2, 0.1); nominal break-away deflections zmax_i(L = f_c) =
  (4e-5, 1e-4, 2e-4, 4e-4) rad fix kz_i = w_i f_c / zmax_i; sz_i = 2.8e5 * kz_i / sum(kz) N m s/rad.
  Sliding friction level L = f_c = 2353 N m, viscous V = f_v = 8683 N m s/rad (nominal);
  the friction effects below change L and V; L is floored at 0.25 f_c and V at 0.
  At rest the elements hold (elastic presliding), giving stiction-like reversals.

3. Joint motor control and currents
-----------------------------------
  Position/speed loop on u (PID with acceleration feed-forward), per unit of J_u:
  tau_m = J_u (a_ref + wc^2 e + 1.6 wc e' + 0.25 wc^3 integral(e)),  e = u_ref - u, wc = 12 rad/s,
  limited to +-1.6e5 N m. u_ref = u0 + the scheme's motion reference (u0: initial static twist).
  Currents i_k = s_k tau_m / (N k_t), shares s_k = (1 + U(-0.03, 0.03))/3 normalised, k_t = 1.1 N m/A.
  Motor speeds w_k = N u' (rad/s at the motor shaft).

4. Dynamometer (electric load motor with torque PI loop)
--------------------------------------------------------
  set point tau_sp(t) (scheme profile) with a per-run error: tau_spe = tau_sp (1 + eps_g) + eps_0,
  eps_g ~ N(0, 0.005) clipped +-0.0125 (<= +-1.5 kN m at 120 kN m), eps_0 ~ N(0, 40 N m).
  command c = tau_spe + 0.5 (tau_spe - y_L) + 4.0 s^-1 * integral(tau_spe - y_L)  (y_L: load cell)
  drive torque tau_d' = (c - tau_d) / 5 ms.
  own torque ripple tau_r = (60 N m + 0.002 |tau_d|) (sin(1200 q + phi) + 0.3 sin(2400 q + 2 phi)),
  phi ~ U(0, 2 pi) per run (1200 = 200 reducer x 6 cycles per load-motor revolution).

5. Sensors (SensorSpec gives noise and resolution; filters are part of the rig)
-------------------------------------------------------------------------------
  torque transducer: 2nd-order Butterworth low-pass, f_c = 20 Hz (zeta = 0.7071), low-frequency
    group delay 2 zeta / (2 pi f_c) = 11.25 ms, then a pure delay torque_lag_s, then white noise
    torque_noise (sd) at the sampling instants.
  load cell: 1st-order low-pass f_c = 10 Hz (lag 15.9 ms), white noise load_noise.
  output encoder: q quantised to encoder_res_deg; qd = backward difference of the quantised
    position over 0.05 s, computed by the drive at 1 kHz (lag 0.025 s).
  motor encoder: u quantised to 2 pi / (motor_encoder_counts N); ud = backward difference over
    0.01 s (lag 0.005 s).
  currents: + white noise current_noise (A); motor speeds: + white noise speed_noise (rad/s).
  joint temperature: quantised to temp_resolution_c.

6. Joint thermal model
----------------------
  C theta' = P_loss - (theta - theta_amb) / R,  P_loss = |F v| + |F_m u'| + (1 - 0.92) |T u'|
  C = 5.0e4 J/K, R = 0.05 K/W, theta_amb = 20 + U(-2, 2) C, theta(0) = temp_joint_c.

7. Numerics
-----------
  Fixed-step classical RK4, dt = 0.25 ms, numba kernel; states recorded every 1 ms; samples are
  taken at the nearest 1 ms record (sample rates 1 Hz - 1 kHz). Initial state: static equilibrium
  with gravity at q = 0 (friction elements unloaded), controller integral preset to hold it.

8. Schemes
----------
  1: 100 s. motion starts at 1 s (cosine speed ramp 2 s) to w_out = rpm 2 pi / 60 / N signed by
     direction, stops from 97 s (2 s ramp). Load set point 0 until 6 s, ramps to direction * 120 kN m
     at 51 s, back to 0 at 96 s. Phases idle [0, 6), load [6, 51), unload [51, 96), idle.
  2: 60 s. motion as scheme 1 (stop from 56 s). Twelve 10 kN m steps from 5 s: each 0.5 s ramp
     ("load") and 2.5 s hold ("hold"), up to 120 kN m at 41 s, unload ramp to 0 at 55 s, idle.
  3: 2 s idle, `periods` periods of a 5th-order Fourier trajectory (period 20 s, base
     w_f = 2 pi / 20), 2 s idle. q_ref = dir * sum_l [a_l/(l w_f) sin(l w_f t) - b_l/(l w_f)
     (cos(l w_f t) - 1)], a = c (0.012, -0.004, 0.006, -0.010, -0.004),
     b = c (0.008, 0.006, -0.005, 0.003, -0.0034), c scaling the peak speed to 0.025 rad/s
     (zero velocity and acceleration at both ends of the excitation). Load set point 0.

9. Effects {name: {"form": f, "scale": s}}, s >= 0, sizes below are at s = 1 and scale linearly;
   s = 0 leaves the run bit-for-bit nominal. theta_ref = 25 C, sg(v) = v / sqrt(v^2 + (2e-4)^2).
-------------------------------------------------------------------------------------------------
  stribeck (adds to L):
    exponential      + 1800 exp(-|v| / 0.004)
    gaussian         + 1800 exp(-(v / 0.004)^2)
    lorentzian       + 1800 / (1 + (v / 0.004)^2)
    root_exponential + 1800 exp(-sqrt(|v| / 0.004))
  temperature_friction (dtheta = theta_ref - theta; vanishes at 25 C):
    coulomb_linear       L += 70 N m/C * dtheta
    exponential          L, V *= 1 + (exp(0.025 dtheta) - 1)
    viscous_arrhenius    V *= 1 + (exp(5000 K (1/(theta+273.15) - 1/(theta_ref+273.15))) - 1)
  load_dependent_friction (|T| transmitted torque):
    coulomb_linear       L += 0.02 |T|
    coulomb_viscous      L += 0.012 |T|,  V += 1.5 f_v |T| / 120 kN m
    coulomb_quadratic    L += 0.022 T^2 / 120 kN m
  asymmetric_friction:
    coulomb              L *= 1 + 0.3 sg(v)
    viscous              V *= 1 + 0.8 sg(v)
    coulomb_viscous      L += 500 sg(v),  V *= 1 + 0.5 sg(v)
  gear_ripple (kinematic error, referenced to zero at the zeroing position 0):
    output   e_o(q) = 1.2e-4 [sin(48 q) + 0.35 sin(96 q + 0.9)] rad, in stage 2
    motor    e_m(u) = 1.0e-4 [sin(100 u) + 0.5 sin(200 u + 2.1)] rad, in stage 1 (intermediate
             pinion mesh, periodic in the motor angle: 100 cycles per output-referred revolution)
    combined 0.7 e_o + 0.7 e_m
  backlash (stage 1, half play b = 1.5e-4 rad, total 3e-4 rad = 1.03 arcmin):
    sharp    B(d) = d - clip(d, -b, b)
    smooth   B(d) = sp(d - b) - sp(-d - b), sp(x) = w ln(1 + exp(x / w)), w = 3e-5 rad
    offset   B(d) = d - clip(d, -0.5 b, 1.5 b)   (play not centred)
  hysteresis (torque H in stage 2 driven by the stage-2 deflection history; F_h = 2500 N m,
    x_r = 4e-4 rad; Bouc-Wen normalised: xi' = d2'/x_r (1 - (beta sgn(d2' xi) + gamma)|xi|^n),
    H = F_h xi):
    bouc_wen            n = 1, beta = gamma = 0.5
    bouc_wen_sharp      n = 3, beta = gamma = 0.5
    bouc_wen_softening  n = 1, beta = 0.9, gamma = 0.1
    iwan                3 elasto-slip elements, y_j' = d2' (1 - max(0, y_j sgn(d2') / r_j)^8),
                        r_j = x_r (0.25, 0.6, 1.2), H = sum_j (F_h / 3) y_j / r_j
  torque_offset (reading only):
    constant           + 1500 N m
    linear_drift       + 30 N m/s * t
    exponential_drift  + 2500 (1 - exp(-t / 40 s)) N m
  time_delay (reading only, on top of the stated lag):
    pure                  pure delay 0.2 s
    first_order           first-order lag, time constant 0.2 s
    pure_plus_first_order pure 0.1 s then first-order 0.1 s
  Out of vocabulary:
    periodic_disturbance (torque tau_x on the output, between transducer and load cell):
      single      1200 sin(2 pi 0.83 t + 0.3) N m
      two_tone    900 sin(2 pi 0.83 t + 0.3) + 700 sin(2 pi 2.9 t + 1.0) N m
    position_dependent_stiffness (k2 -> k2 * factor):
      harmonic    1 + 0.06 sin(2 q + 0.4)
      linear      1 + 0.05 q / rad
    load_cell_drift (torque_load reading only):
      linear      + 25 N m/s * t
      gain        reading * (1 + 0.02)
    encoder_scale_error (output encoder reading only, before quantisation):
      scale       q (1 + 1.5e-4)
      drift       q + 2e-6 rad/s * t
"""
from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import numpy as np
import pandas as pd
from numba import njit

SEED_IS_CAMPAIGN = True
REDUCTION = 11000.0
RIG_NAME = "validation-rig-F"

DT = 2.5e-4  # s, RK4 step
REC_EVERY = 4  # steps per 1 ms record
DT_REC = DT * REC_EVERY
GRAV = 9.81
T_RATED = 120000.0
THETA_REF = 25.0
QD_WINDOW_S = 0.05
UD_WINDOW_S = 0.01
TRANSDUCER_FC_HZ = 20.0
TRANSDUCER_ZETA = 1.0 / math.sqrt(2.0)
LOADCELL_FC_HZ = 10.0
N2_INTERMEDIATE = 100.0

EFFECT_FORMS: dict[str, tuple[str, ...]] = {
    "stribeck": ("exponential", "gaussian", "lorentzian", "root_exponential"),
    "temperature_friction": ("coulomb_linear", "exponential", "viscous_arrhenius"),
    "load_dependent_friction": ("coulomb_linear", "coulomb_viscous", "coulomb_quadratic"),
    "asymmetric_friction": ("coulomb", "viscous", "coulomb_viscous"),
    "gear_ripple": ("output", "motor", "combined"),
    "backlash": ("sharp", "smooth", "offset"),
    "hysteresis": ("bouc_wen", "bouc_wen_sharp", "bouc_wen_softening", "iwan"),
    "torque_offset": ("constant", "linear_drift", "exponential_drift"),
    "time_delay": ("pure", "first_order", "pure_plus_first_order"),
    "periodic_disturbance": ("single", "two_tone"),
    "position_dependent_stiffness": ("harmonic", "linear"),
    "load_cell_drift": ("linear", "gain"),
    "encoder_scale_error": ("scale", "drift"),
}
OUT_OF_VOCABULARY: tuple[str, ...] = (
    "periodic_disturbance", "position_dependent_stiffness", "load_cell_drift", "encoder_scale_error",
)
_SLOTS = {name: i for i, name in enumerate(EFFECT_FORMS)}
E_STRIB, E_TFRIC, E_LFRIC, E_ASYM, E_RIPPLE, E_BACKLASH, E_HYST = 0, 1, 2, 3, 4, 5, 6
E_OFFSET, E_DELAY, E_PDIST, E_PSTIFF, E_LCDRIFT, E_ENC = 7, 8, 9, 10, 11, 12
N_SLOTS = len(EFFECT_FORMS)

# parameter vector indices
(P_I, P_JD, P_MRX, P_MRY, P_FC, P_FV, P_K1, P_K2, P_C1, P_C2, P_JP, P_JU, P_FMC, P_BM, P_WT,
 P_TLC, P_TAUI, P_KPD, P_KID, P_RA0, P_RA1, P_RPH, P_SPG, P_SPB, P_CTH, P_RTH, P_TAMB, P_WC,
 P_UOFF, P_GK, P_GS) = range(31)
P_GW = P_GS + 4
N_PARAMS = P_GW + 4
GMS_W = (0.4, 0.3, 0.2, 0.1)
GMS_ZMAX = (4e-5, 1e-4, 2e-4, 4e-4)

# state indices: 0 q, 1 qd, 2 p, 3 pd, 4 u, 5 ud, 6 int e, 7 tau_d, 8 int dyn, 9 yT, 10 yT',
# 11 yL, 12 theta, 13-15 hysteresis, 16-19 friction elements
N_STATES = 20
# record channels
R_Q, R_QD, R_U, R_UD, R_T, R_TL, R_YT, R_YL, R_TH, R_TM, R_P = range(11)
N_REC = 11


@dataclass(frozen=True)
class SensorSpec:
    """Sensor noise and resolution of one run (what varies between acquisition set-ups)."""

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
    """One emulated run: sampled channels, metadata, and the noise-free truth."""

    samples: pd.DataFrame
    meta: dict
    truth: pd.DataFrame


@njit(cache=True)
def _ramp_pos(tau: float, dur: float) -> float:
    if tau <= 0.0:
        return 0.0
    if tau >= dur:
        return tau - 0.5 * dur
    return 0.5 * (tau - dur / math.pi * math.sin(math.pi * tau / dur))


@njit(cache=True)
def _ramp_vel(tau: float, dur: float) -> float:
    if tau <= 0.0:
        return 0.0
    if tau >= dur:
        return 1.0
    return 0.5 * (1.0 - math.cos(math.pi * tau / dur))


@njit(cache=True)
def _ramp_acc(tau: float, dur: float) -> float:
    if tau <= 0.0 or tau >= dur:
        return 0.0
    return 0.5 * math.pi / dur * math.sin(math.pi * tau / dur)


@njit(cache=True)
def _motion_ref(t: float, refp: np.ndarray) -> tuple:
    """Reference (position, velocity, acceleration) of the motor angle u, output-referred."""
    if refp[0] == 0.0:  # constant speed with start and stop ramps
        w, t_on, t_acc, t_off, t_dec = refp[1], refp[2], refp[3], refp[4], refp[5]
        pos = w * (_ramp_pos(t - t_on, t_acc) - _ramp_pos(t - t_off, t_dec))
        vel = w * (_ramp_vel(t - t_on, t_acc) - _ramp_vel(t - t_off, t_dec))
        acc = w * (_ramp_acc(t - t_on, t_acc) - _ramp_acc(t - t_off, t_dec))
        return pos, vel, acc
    t0, t1, wf, sgn = refp[1], refp[2], refp[3], refp[4]
    if t < t0 or t > t1:
        return 0.0, 0.0, 0.0
    tt = t - t0
    pos = 0.0
    vel = 0.0
    acc = 0.0
    for l in range(1, 6):
        a = refp[4 + l]
        b = refp[9 + l]
        lw = l * wf
        s = math.sin(lw * tt)
        c = math.cos(lw * tt)
        pos += a / lw * s - b / lw * (c - 1.0)
        vel += a * c + b * s
        acc += lw * (-a * s + b * c)
    return sgn * pos, sgn * vel, sgn * acc


@njit(cache=True)
def _softplus(x: float, w: float) -> float:
    y = x / w
    return w * (max(y, 0.0) + math.log1p(math.exp(-abs(y))))


@njit(cache=True)
def _rhs(t, x, P, ef, es, refp, bt, bv, dx, aux):
    q = x[0]
    qd = x[1]
    p = x[2]
    pd = x[3]
    u = x[4]
    ud = x[5]
    for i in range(N_STATES):
        dx[i] = 0.0
    # kinematic error (gear_ripple)
    eo = 0.0
    eod = 0.0
    em = 0.0
    emd = 0.0
    s = es[E_RIPPLE]
    if s != 0.0:
        f = ef[E_RIPPLE]
        if f == 0 or f == 2:
            a = s * 1.2e-4 * (1.0 if f == 0 else 0.7)
            eo = a * (math.sin(48.0 * q) + 0.35 * math.sin(96.0 * q + 0.9) - 0.35 * math.sin(0.9))
            eod = a * (48.0 * math.cos(48.0 * q) + 0.35 * 96.0 * math.cos(96.0 * q + 0.9)) * qd
        if f == 1 or f == 2:
            a = s * 1.0e-4 * (1.0 if f == 1 else 0.7)
            em = a * (math.sin(100.0 * u) + 0.5 * math.sin(200.0 * u + 2.1) - 0.5 * math.sin(2.1))
            emd = a * (100.0 * math.cos(100.0 * u) + 0.5 * 200.0 * math.cos(200.0 * u + 2.1)) * ud
    d1 = u - p - em
    d1d = ud - pd - emd
    d2 = p - q - eo
    d2d = pd - qd - eod
    # stage 1 with backlash
    el1 = d1
    s = es[E_BACKLASH]
    if s != 0.0:
        b = s * 1.5e-4
        f = ef[E_BACKLASH]
        if f == 0:
            el1 = d1 - min(max(d1, -b), b)
        elif f == 1:
            el1 = _softplus(d1 - b, 3e-5) - _softplus(-d1 - b, 3e-5)
        else:
            el1 = d1 - min(max(d1, -0.5 * b), 1.5 * b)
    t1 = P[P_K1] * el1 + P[P_C1] * d1d
    # stage 2 with optional position-dependent stiffness and hysteresis
    k2 = P[P_K2]
    s = es[E_PSTIFF]
    if s != 0.0:
        if ef[E_PSTIFF] == 0:
            k2 = k2 * (1.0 + s * 0.06 * math.sin(2.0 * q + 0.4))
        else:
            k2 = k2 * (1.0 + s * 0.05 * q)
    tq = k2 * d2 + P[P_C2] * d2d
    s = es[E_HYST]
    if s != 0.0:
        f = ef[E_HYST]
        xr = 4e-4
        fh = 2500.0
        if f <= 2:
            xi = x[13]
            if f == 0:
                n, bh, gh = 1.0, 0.5, 0.5
            elif f == 1:
                n, bh, gh = 3.0, 0.5, 0.5
            else:
                n, bh, gh = 1.0, 0.9, 0.1
            sg = 1.0 if d2d * xi >= 0.0 else -1.0
            dx[13] = d2d / xr * (1.0 - (bh * sg + gh) * abs(xi) ** n)
            tq += s * fh * xi
        else:
            sd = 1.0 if d2d >= 0.0 else -1.0
            for j in range(3):
                r = xr * (0.25, 0.6, 1.2)[j]
                y = x[13 + j]
                e = y * sd / r
                c = e ** 8 if e > 0.0 else 0.0
                dx[13 + j] = d2d * (1.0 - c)
                tq += s * fh / 3.0 * y / r
    # output bearing friction: level L, viscous V
    v = qd
    th = x[12]
    fc = P[P_FC]
    lev = fc
    vis = P[P_FV]
    s = es[E_STRIB]
    if s != 0.0:
        f = ef[E_STRIB]
        r = v / 0.004
        if f == 0:
            shape = math.exp(-abs(r))
        elif f == 1:
            shape = math.exp(-r * r)
        elif f == 2:
            shape = 1.0 / (1.0 + r * r)
        else:
            shape = math.exp(-math.sqrt(abs(r)))
        lev += s * 1800.0 * shape
    s = es[E_TFRIC]
    if s != 0.0:
        f = ef[E_TFRIC]
        dth = THETA_REF - th
        if f == 0:
            lev += s * 70.0 * dth
        elif f == 1:
            m = 1.0 + s * (math.exp(0.025 * dth) - 1.0)
            lev *= m
            vis *= m
        else:
            vis *= 1.0 + s * (math.exp(5000.0 * (1.0 / (th + 273.15) - 1.0 / (THETA_REF + 273.15))) - 1.0)
    s = es[E_LFRIC]
    if s != 0.0:
        f = ef[E_LFRIC]
        ta = abs(tq)
        if f == 0:
            lev += s * 0.02 * ta
        elif f == 1:
            lev += s * 0.012 * ta
            vis += s * 1.5 * P[P_FV] * ta / T_RATED
        else:
            lev += s * 0.022 * ta * ta / T_RATED
    s = es[E_ASYM]
    if s != 0.0:
        f = ef[E_ASYM]
        sg = v / math.sqrt(v * v + 4e-8)
        if f == 0:
            lev *= 1.0 + s * 0.3 * sg
        elif f == 1:
            vis *= 1.0 + s * 0.8 * sg
        else:
            lev += s * 500.0 * sg
            vis *= 1.0 + s * 0.5 * sg
    lev = max(lev, 0.25 * fc)
    vis = max(vis, 0.0)
    fr = vis * v
    for i in range(4):
        kz = P[P_GK + i]
        zmax = P[P_GW + i] * lev / kz
        zi = x[16 + i]
        dz = v - abs(v) * zi / zmax
        dx[16 + i] = dz
        fr += kz * zi + P[P_GS + i] * dz
    # disturbance torque on the output (out of vocabulary)
    dist = 0.0
    s = es[E_PDIST]
    if s != 0.0:
        dist = 1200.0 if ef[E_PDIST] == 0 else 900.0
        dist = s * dist * math.sin(2.0 * math.pi * 0.83 * t + 0.3)
        if ef[E_PDIST] == 1:
            dist += s * 700.0 * math.sin(2.0 * math.pi * 2.9 * t + 1.0)
    # dynamometer
    tsp = np.interp(t, bt, bv)
    tspe = tsp * (1.0 + P[P_SPG]) + P[P_SPB]
    yl = x[11]
    cmd = tspe + P[P_KPD] * (tspe - yl) + P[P_KID] * x[8]
    dx[8] = tspe - yl
    dx[7] = (cmd - x[7]) / P[P_TAUI]
    ph = P[P_RPH]
    rip = (P[P_RA0] + P[P_RA1] * abs(x[7])) * (math.sin(1200.0 * q + ph) + 0.3 * math.sin(2400.0 * q + 2.0 * ph))
    grav = GRAV * (P[P_MRX] * math.sin(q) + P[P_MRY] * math.cos(q))
    qdd = (tq - x[7] - rip - grav - fr - dist) / (P[P_I] + P[P_JD])
    tl = x[7] + rip + P[P_JD] * qdd
    # intermediate shaft
    pdd = (t1 - tq) / P[P_JP]
    # motor control
    pos, vel, acc = _motion_ref(t, refp)
    e = P[P_UOFF] + pos - u
    wc = P[P_WC]
    ju = P[P_JU]
    tm = ju * (acc + wc * wc * e + 1.6 * wc * (vel - ud) + 0.25 * wc * wc * wc * x[6])
    tm = min(max(tm, -1.6e5), 1.6e5)
    dx[6] = e
    fm = P[P_FMC] * ud / math.sqrt(ud * ud + 1e-8) + P[P_BM] * ud
    udd = (tm - t1 - fm) / ju
    # sensors' filters
    wt = P[P_WT]
    dx[9] = x[10]
    dx[10] = wt * wt * (tq - x[9]) - 2.0 * TRANSDUCER_ZETA * wt * x[10]
    dx[11] = (tl - yl) / P[P_TLC]
    # thermal
    ploss = abs(fr * v) + abs(fm * ud) + 0.08 * abs(tq * ud)
    dx[12] = (ploss - (th - P[P_TAMB]) / P[P_RTH]) / P[P_CTH]
    dx[0] = qd
    dx[1] = qdd
    dx[2] = pd
    dx[3] = pdd
    dx[4] = ud
    dx[5] = udd
    aux[0] = tq
    aux[1] = tl
    aux[2] = tm


@njit(cache=True)
def _simulate(nsteps, x0, P, ef, es, refp, bt, bv):
    nrec = nsteps // REC_EVERY + 1
    rec = np.empty((nrec, N_REC))
    x = x0.copy()
    k1 = np.empty(N_STATES)
    k2 = np.empty(N_STATES)
    k3 = np.empty(N_STATES)
    k4 = np.empty(N_STATES)
    xt = np.empty(N_STATES)
    aux = np.empty(3)
    aux_d = np.empty(3)
    j = 0
    for n in range(nsteps + 1):
        t = n * DT
        _rhs(t, x, P, ef, es, refp, bt, bv, k1, aux)
        if n % REC_EVERY == 0:
            rec[j, R_Q] = x[0]
            rec[j, R_QD] = x[1]
            rec[j, R_U] = x[4]
            rec[j, R_UD] = x[5]
            rec[j, R_T] = aux[0]
            rec[j, R_TL] = aux[1]
            rec[j, R_YT] = x[9]
            rec[j, R_YL] = x[11]
            rec[j, R_TH] = x[12]
            rec[j, R_TM] = aux[2]
            rec[j, R_P] = x[2]
            j += 1
        if n == nsteps:
            break
        for i in range(N_STATES):
            xt[i] = x[i] + 0.5 * DT * k1[i]
        _rhs(t + 0.5 * DT, xt, P, ef, es, refp, bt, bv, k2, aux_d)
        for i in range(N_STATES):
            xt[i] = x[i] + 0.5 * DT * k2[i]
        _rhs(t + 0.5 * DT, xt, P, ef, es, refp, bt, bv, k3, aux_d)
        for i in range(N_STATES):
            xt[i] = x[i] + DT * k3[i]
        _rhs(t + DT, xt, P, ef, es, refp, bt, bv, k4, aux_d)
        for i in range(N_STATES):
            x[i] += DT / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i])
    return rec


@njit(cache=True)
def _first_order(y: np.ndarray, tau: float, dt: float) -> np.ndarray:
    """Exact-discretised first-order lag of a sampled signal, started at rest at y[0]."""
    out = np.empty_like(y)
    a = math.exp(-dt / tau)
    acc = y[0]
    for i in range(y.size):
        acc = a * acc + (1.0 - a) * y[i]
        out[i] = acc
    return out


def _delay(y: np.ndarray, t: np.ndarray, d: float) -> np.ndarray:
    """Pure delay d (s) by linear interpolation on the 1 ms record, holding the first value."""
    return np.interp(t - d, t, y, left=y[0])


def _backward_diff(x: np.ndarray, window_s: float) -> np.ndarray:
    """Drive-side velocity estimate: backward difference over window_s on the 1 ms record."""
    w = int(round(window_s / DT_REC))
    out = np.zeros_like(x)
    out[w:] = (x[w:] - x[:-w]) / (w * DT_REC)
    k = np.arange(1, min(w, x.size))
    out[k] = (x[k] - x[0]) / (k * DT_REC)
    return out


def _draw_params(seed: int) -> dict:
    """The campaign's physical rig: nominal values times 1 + U(-0.08, 0.08), keyed by seed."""
    rng = np.random.default_rng([int(seed), 0x46])

    def f(v: float) -> float:
        return v * (1.0 + rng.uniform(-0.08, 0.08))

    par = {
        "I": f(6685.0), "J_d": f(400.0), "mr_x": f(20.8), "mr_y": f(-34.5), "f_c": f(2353.0),
        "f_v": f(8683.0), "k1": f(3.0e7), "k2": f(2.6e7), "c1": f(6.0e4), "c2": f(5.0e4),
        "J_p": f(2000.0), "J_m": f(2.2e-4), "F_mc": f(2500.0), "b_m": f(3.0e4),
        "transducer_fc_hz": f(TRANSDUCER_FC_HZ), "loadcell_fc_hz": f(LOADCELL_FC_HZ),
        "dyn_tau_i": f(0.005), "ripple_a0": f(60.0), "ripple_a1": f(0.002), "C_th": f(5.0e4),
        "R_th": f(0.05), "k_t": f(1.1),
    }
    par["theta_amb"] = 20.0 + rng.uniform(-2.0, 2.0)
    shares = (1.0 + rng.uniform(-0.03, 0.03, 3)) / 3.0
    par["shares"] = shares / shares.sum()
    return par


def _fourier_coeffs() -> tuple[np.ndarray, np.ndarray, float]:
    """Scheme 3 coefficients scaled so the peak output speed is 0.025 rad/s."""
    a = np.array([0.012, -0.004, 0.006, -0.010, -0.004])
    b = np.array([0.008, 0.006, -0.005, 0.003, -0.0034])
    wf = 2.0 * math.pi / 20.0
    tt = np.linspace(0.0, 20.0, 4001)
    ll = np.arange(1, 6)[:, None]
    vel = (a[:, None] * np.cos(ll * wf * tt) + b[:, None] * np.sin(ll * wf * tt)).sum(axis=0)
    c = 0.025 / np.abs(vel).max()
    return a * c, b * c, wf


def _scheme_setup(scheme: int, rpm: float | None, direction: int, periods: int):
    """Duration, motion reference vector, load set-point breakpoints, phase function."""
    if scheme in (1, 2):
        w = direction * rpm * 2.0 * math.pi / 60.0 / REDUCTION
        if scheme == 1:
            dur = 100.0
            refp = np.array([0.0, w, 1.0, 2.0, 97.0, 2.0])
            bt = np.array([0.0, 6.0, 51.0, 96.0, dur])
            bv = np.array([0.0, 0.0, direction * T_RATED, 0.0, 0.0])

            def phase(t: np.ndarray) -> np.ndarray:
                ph = np.full(t.size, "idle", dtype=object)
                ph[(t >= 6.0) & (t < 51.0)] = "load"
                ph[(t >= 51.0) & (t < 96.0)] = "unload"
                return ph
        else:
            dur = 60.0
            refp = np.array([0.0, w, 1.0, 2.0, 56.0, 2.0])
            bt_l = [0.0, 5.0]
            bv_l = [0.0, 0.0]
            for k in range(1, 13):
                t0 = 5.0 + 3.0 * (k - 1)
                bt_l += [t0 + 0.5, t0 + 3.0]
                bv_l += [direction * 1e4 * k, direction * 1e4 * k]
            bt_l += [55.0, dur]
            bv_l += [0.0, 0.0]
            bt = np.array(bt_l)
            bv = np.array(bv_l)

            def phase(t: np.ndarray) -> np.ndarray:
                ph = np.full(t.size, "idle", dtype=object)
                inside = (t >= 5.0) & (t < 41.0)
                blk = np.mod(t - 5.0, 3.0)
                ph[inside & (blk < 0.5)] = "load"
                ph[inside & (blk >= 0.5)] = "hold"
                ph[(t >= 41.0) & (t < 55.0)] = "unload"
                return ph
    else:
        a, b, wf = _fourier_coeffs()
        t1 = 2.0 + 20.0 * periods
        dur = t1 + 2.0
        refp = np.concatenate(([1.0, 2.0, t1, wf, float(direction)], a, b))
        bt = np.array([0.0, dur])
        bv = np.array([0.0, 0.0])

        def phase(t: np.ndarray) -> np.ndarray:
            ph = np.full(t.size, "idle", dtype=object)
            ph[(t >= 2.0) & (t < t1)] = "excite"
            return ph
    return dur, refp, bt, bv, phase


def _validate(scheme, rpm, direction, temp, effects, seed, sensors, periods, run) -> None:
    if isinstance(scheme, bool) or not isinstance(scheme, (int, np.integer)) or scheme not in (1, 2, 3):
        raise ValueError(f"scheme must be 1, 2 or 3, got {scheme!r}")
    if scheme == 3:
        if rpm is not None:
            raise ValueError("motor_speed_rpm must be None for scheme 3 (the trajectory sets the speed)")
    else:
        if rpm is None or isinstance(rpm, bool) or not isinstance(rpm, (int, float, np.integer, np.floating)):
            raise ValueError(f"scheme {scheme} needs a motor_speed_rpm number, got {rpm!r}")
        if not (math.isfinite(rpm) and 0.0 < rpm <= 3300.0):
            raise ValueError(f"motor_speed_rpm must be in (0, 3300] r/min, got {rpm!r}")
    if isinstance(direction, bool) or direction not in (1, -1):
        raise ValueError(f"direction must be +1 or -1, got {direction!r}")
    if isinstance(temp, bool) or not isinstance(temp, (int, float, np.integer, np.floating)) \
            or not math.isfinite(temp) or not -30.0 <= temp <= 90.0:
        raise ValueError(f"temp_joint_c must be a finite temperature in [-30, 90] C, got {temp!r}")
    for name, val in (("seed", seed), ("run", run)):
        if isinstance(val, bool) or not isinstance(val, (int, np.integer)) or val < 0:
            raise ValueError(f"{name} must be a non-negative integer, got {val!r}")
    if isinstance(periods, bool) or not isinstance(periods, (int, np.integer)) or not 1 <= periods <= 50:
        raise ValueError(f"periods must be an integer in [1, 50], got {periods!r}")
    if not isinstance(sensors, SensorSpec):
        raise ValueError(f"sensors must be a SensorSpec, got {type(sensors).__name__}")
    fs = sensors.sample_rate_hz
    if not (math.isfinite(fs) and 1.0 <= fs <= 1000.0):
        raise ValueError(f"sample_rate_hz must be in [1, 1000] Hz, got {fs!r}")
    if not (math.isfinite(sensors.encoder_res_deg) and sensors.encoder_res_deg > 0.0):
        raise ValueError(f"encoder_res_deg must be > 0, got {sensors.encoder_res_deg!r}")
    if not (math.isfinite(sensors.temp_resolution_c) and sensors.temp_resolution_c > 0.0):
        raise ValueError(f"temp_resolution_c must be > 0, got {sensors.temp_resolution_c!r}")
    if not isinstance(sensors.motor_encoder_counts, (int, np.integer)) or sensors.motor_encoder_counts < 1:
        raise ValueError(f"motor_encoder_counts must be a positive integer, got {sensors.motor_encoder_counts!r}")
    for fld in ("torque_noise", "torque_lag_s", "load_noise", "current_noise", "speed_noise"):
        val = getattr(sensors, fld)
        if not (math.isfinite(val) and val >= 0.0):
            raise ValueError(f"{fld} must be finite and >= 0, got {val!r}")
    if sensors.torque_lag_s > 5.0:
        raise ValueError(f"torque_lag_s must be <= 5 s, got {sensors.torque_lag_s!r}")
    if not isinstance(effects, dict):
        raise ValueError("effects must be a dict {name: {'form': f, 'scale': s}}")
    for name, spec in effects.items():
        if name not in EFFECT_FORMS:
            raise ValueError(f"unknown effect {name!r}; known: {sorted(EFFECT_FORMS)}")
        if not isinstance(spec, dict) or set(spec) != {"form", "scale"}:
            raise ValueError(f"effect {name!r} needs exactly the keys 'form' and 'scale', got {spec!r}")
        if spec["form"] not in EFFECT_FORMS[name]:
            raise ValueError(f"effect {name!r} has no form {spec['form']!r}; forms: {EFFECT_FORMS[name]}")
        s = spec["scale"]
        if isinstance(s, bool) or not isinstance(s, (int, float, np.integer, np.floating)) \
                or not math.isfinite(s) or s < 0.0:
            raise ValueError(f"effect {name!r} scale must be a finite number >= 0, got {s!r}")


def simulate_run(scheme: int, motor_speed_rpm: float | None, direction: int, temp_joint_c: float,
                 effects: dict[str, dict], *, seed: int, sensors: SensorSpec, periods: int = 3,
                 run: int = 0) -> RigRun:
    """Emulate one run of the J4 platform; `seed` fixes the rig, `run` the run's noise.

    Returns sampled channels (SI units, degC), metadata (what a data sheet states) and the
    noise-free truth on the same time grid. Deterministic in all arguments.
    """
    _validate(scheme, motor_speed_rpm, direction, temp_joint_c, effects, seed, sensors, periods, run)
    par = _draw_params(seed)
    rng = np.random.default_rng([int(seed), int(run), 0x52])
    sp_gain = float(np.clip(rng.normal(0.0, 0.005), -0.0125, 0.0125))
    sp_bias = float(rng.normal(0.0, 40.0))
    rip_phase = float(rng.uniform(0.0, 2.0 * math.pi))

    dur, refp, bt, bv, phase_fn = _scheme_setup(int(scheme), motor_speed_rpm, int(direction), int(periods))

    ju = 3.0 * par["J_m"] * REDUCTION ** 2
    wc = 12.0
    grav0 = GRAV * par["mr_y"]  # gravity torque at q = 0
    d1_0 = grav0 / par["k1"]
    d2_0 = grav0 / par["k2"]
    u0 = d1_0 + d2_0
    P = np.zeros(N_PARAMS)
    P[P_I], P[P_JD], P[P_MRX], P[P_MRY] = par["I"], par["J_d"], par["mr_x"], par["mr_y"]
    P[P_FC], P[P_FV], P[P_K1], P[P_K2] = par["f_c"], par["f_v"], par["k1"], par["k2"]
    P[P_C1], P[P_C2], P[P_JP], P[P_JU] = par["c1"], par["c2"], par["J_p"], ju
    P[P_FMC], P[P_BM] = par["F_mc"], par["b_m"]
    P[P_WT] = 2.0 * math.pi * par["transducer_fc_hz"]
    P[P_TLC] = 1.0 / (2.0 * math.pi * par["loadcell_fc_hz"])
    P[P_TAUI], P[P_KPD], P[P_KID] = par["dyn_tau_i"], 0.5, 4.0
    P[P_RA0], P[P_RA1], P[P_RPH] = par["ripple_a0"], par["ripple_a1"], rip_phase
    P[P_SPG], P[P_SPB] = sp_gain, sp_bias
    P[P_CTH], P[P_RTH], P[P_TAMB] = par["C_th"], par["R_th"], par["theta_amb"]
    P[P_WC], P[P_UOFF] = wc, u0
    kz = np.array([w * par["f_c"] / z for w, z in zip(GMS_W, GMS_ZMAX)])
    P[P_GK:P_GK + 4] = kz
    P[P_GS:P_GS + 4] = 2.8e5 * kz / kz.sum()
    P[P_GW:P_GW + 4] = GMS_W

    ef = np.zeros(N_SLOTS, dtype=np.int64)
    es = np.zeros(N_SLOTS)
    for name, spec in effects.items():
        if float(spec["scale"]) != 0.0:
            ef[_SLOTS[name]] = EFFECT_FORMS[name].index(spec["form"])
            es[_SLOTS[name]] = float(spec["scale"])

    x0 = np.zeros(N_STATES)
    x0[2] = d2_0
    x0[4] = u0
    x0[6] = grav0 / (ju * 0.25 * wc ** 3)
    x0[9] = grav0
    x0[12] = float(temp_joint_c)

    nsteps = int(round(dur / DT))
    rec = _simulate(nsteps, x0, P, ef, es, refp, bt, bv)
    t_rec = np.arange(rec.shape[0]) * DT_REC

    # torque transducer reading (noise-free): filter -> stated lag -> delay effect -> offset
    y_t = rec[:, R_YT].copy()
    s = es[E_DELAY]
    pure = sensors.torque_lag_s
    tau1 = 0.0
    if s != 0.0:
        form = ef[E_DELAY]
        pure += s * (0.2 if form == 0 else (0.1 if form == 2 else 0.0))
        tau1 = s * (0.2 if form == 1 else (0.1 if form == 2 else 0.0))
    if pure != 0.0:
        y_t = _delay(y_t, t_rec, pure)
    if tau1 != 0.0:
        y_t = _first_order(y_t, tau1, DT_REC)
    s = es[E_OFFSET]
    if s != 0.0:
        form = ef[E_OFFSET]
        if form == 0:
            y_t = y_t + s * 1500.0
        elif form == 1:
            y_t = y_t + s * 30.0 * t_rec
        else:
            y_t = y_t + s * 2500.0 * (1.0 - np.exp(-t_rec / 40.0))
    y_l = rec[:, R_YL].copy()
    s = es[E_LCDRIFT]
    if s != 0.0:
        y_l = y_l + s * 25.0 * t_rec if ef[E_LCDRIFT] == 0 else y_l * (1.0 + s * 0.02)

    # encoders and drive-side velocity estimates on the 1 ms record
    q_true = rec[:, R_Q]
    q_read = q_true
    s = es[E_ENC]
    if s != 0.0:
        q_read = q_true * (1.0 + s * 1.5e-4) if ef[E_ENC] == 0 else q_true + s * 2e-6 * t_rec
    res_q = math.radians(sensors.encoder_res_deg)
    q_quant = np.round(q_read / res_q) * res_q
    res_u = 2.0 * math.pi / (sensors.motor_encoder_counts * REDUCTION)
    u_quant = np.round(rec[:, R_U] / res_u) * res_u
    qd_est = _backward_diff(q_quant, QD_WINDOW_S)
    ud_est = _backward_diff(u_quant, UD_WINDOW_S)

    # sampling at the nearest 1 ms record
    fs = float(sensors.sample_rate_hz)
    n_samp = int(math.floor(dur * fs + 1e-9)) + 1
    idx = np.round(np.arange(n_samp) * (1.0 / (fs * DT_REC))).astype(np.int64)
    idx = idx[idx < rec.shape[0]]
    n = idx.size
    t = idx * DT_REC
    truth = pd.DataFrame({
        "t": t,
        "q": q_true[idx],
        "qd": rec[idx, R_QD],
        "u": rec[idx, R_U],
        "ud": rec[idx, R_UD],
    })
    truth["twist"] = truth["u"].to_numpy() - truth["q"].to_numpy()
    truth["torque"] = y_t[idx]
    truth["torque_load"] = y_l[idx]
    truth["torque_joint"] = rec[idx, R_T]
    truth["temp_joint"] = rec[idx, R_TH]

    tm = rec[idx, R_TM]
    w_mot = REDUCTION * rec[idx, R_UD]
    noise_t = rng.normal(0.0, 1.0, n) * sensors.torque_noise
    noise_l = rng.normal(0.0, 1.0, n) * sensors.load_noise
    noise_i = rng.normal(0.0, 1.0, (3, n)) * sensors.current_noise
    noise_w = rng.normal(0.0, 1.0, (3, n)) * sensors.speed_noise
    samples = pd.DataFrame({
        "t": t,
        "q": q_quant[idx],
        "qd": qd_est[idx],
        "u": u_quant[idx],
        "ud": ud_est[idx],
        "torque": y_t[idx] + noise_t,
        "torque_load": y_l[idx] + noise_l,
        "temp_joint": np.round(rec[idx, R_TH] / sensors.temp_resolution_c) * sensors.temp_resolution_c,
        "phase": phase_fn(t),
    })
    for k in range(3):
        samples[f"i_m{k + 1}"] = par["shares"][k] * tm / (REDUCTION * par["k_t"]) + noise_i[k]
    for k in range(3):
        samples[f"w_m{k + 1}"] = w_mot + noise_w[k]

    tf_lag = 2.0 * TRANSDUCER_ZETA / (2.0 * math.pi * TRANSDUCER_FC_HZ)
    lc_lag = 1.0 / (2.0 * math.pi * LOADCELL_FC_HZ)
    sensor_sheet = {
        "q": {"resolution": res_q, "unit": "rad"},
        "u": {"resolution": res_u, "unit": "rad"},
        "qd": {"method": "backward difference of the quantised output encoder, computed at 1 kHz",
               "window_s": QD_WINDOW_S, "lag_s": QD_WINDOW_S / 2.0},
        "ud": {"method": "backward difference of the quantised motor encoder, computed at 1 kHz",
               "window_s": UD_WINDOW_S, "lag_s": UD_WINDOW_S / 2.0},
        "torque": {"noise_sd": sensors.torque_noise, "lag_s": tf_lag + sensors.torque_lag_s,
                   "filter": f"2nd-order Butterworth low-pass {TRANSDUCER_FC_HZ} Hz"},
        "torque_load": {"noise_sd": sensors.load_noise, "lag_s": lc_lag,
                        "filter": f"1st-order low-pass {LOADCELL_FC_HZ} Hz"},
        "temp_joint": {"resolution": sensors.temp_resolution_c},
    }
    for k in range(1, 4):
        sensor_sheet[f"i_m{k}"] = {"noise_sd": sensors.current_noise}
        sensor_sheet[f"w_m{k}"] = {"noise_sd": sensors.speed_noise}
    meta = {
        "scheme": int(scheme),
        "motor_speed_rpm": None if scheme == 3 else float(motor_speed_rpm),
        "direction": int(direction),
        "reduction": REDUCTION,
        "rig": RIG_NAME,
        "source": "emulator",
        "sample_rate_hz": fs,
        "duration_s": float(t[-1]),
        "temp_joint_c": float(temp_joint_c),
        "sensor_spec": asdict(sensors),
        "sensors": sensor_sheet,
        "seed": int(seed),
        "run": int(run),
    }
    if scheme == 3:
        meta["periods"] = int(periods)
    return RigRun(samples=samples, meta=meta, truth=truth)
