"""Rig Z: an independent validation simulator of the CMOR J4 joint test bench.

Written from the paper (Eq. 4, Table 3, Eq. 5, schemes 1-3) and the shared docs only; it shares
no code with the company's emulator or other rigs. Deterministic per (campaign seed, run index).

DATA SHEET (SI units; angles output-referred unless said; temperatures in degC)
===============================================================================

Machine (drawn once per campaign seed, rng = numpy default_rng([seed, 20240611]);
each value = nominal * (1 + s*z), z ~ N(0,1) clipped to +-2.5, s = spread below)
    I     = 6685.166 kg m^2        spread 2 %      output inertia (Table 3)
    mr_x  = 20.779 kg m            spread 2 %
    mr_y  = -34.543 kg m           spread 2 %
    f_v   = 8683.272 N m s/rad     spread 2 %
    f_c   = 2352.660 N m           spread 2 %
    g     = 9.81 m/s^2             exact
    N     = 11000                  exact (reduction)
    Transmission (exponential stiffening, temperature-dependent stiffness):
      T_el(D) = sgn(D) * K(Tj) / b * (exp(b |D|) - 1),   D = u - q (twist) [+ kinematic error]
      b = ln(1.6) / D_r, D_r = 0.5 deg = 8.7266e-3 rad (stiffness at rated = 1.6 x initial)
      K(20 degC) = 120e3 * b / 0.6 = 1.0771e7 N m/rad  spread 3 %  (so T_el(0.5 deg) = 120 kN m)
      K(Tj) = K(20) * (1 - 1.5e-3 * (Tj - 20))
      damping D_t = 5.4e4 N m s/rad (spread 3 %) on the twist rate.
      Transmitted torque T = T_el(D_eff) + D_t * (w - v) [+ hysteresis torque]
    Output balance (paper Eq. 4 plus the load, Karnopp stick band):
      I dv/dt = T - tau_L - g (mr_x sin q + mr_y cos q) - F
      sliding (|v| >= v_b or breaking away):  F = f_c sgn(v) + f_v v
      stick band |v| < v_b = 3e-4 rad/s: if |F_ext| <= F_s the output is held (v = 0,
      F = F_ext = T - tau_L - gravity), else it slips with F = F_s sgn(F_ext) + f_v v;
      at nominal F_s = f_c (breakaway = Coulomb level).
    Drive: three motors on one differential input, each k_t = 0.9 N m/A (spread 2 %),
      rotor J_m = 1.2e-3 kg m^2 each, so output-referred J_M = 3 J_m N^2 = 4.356e5 kg m^2;
      motor-side viscous B_M = 2.0e4 N m s/rad (output-referred); gear efficiency eta = 0.92
      from current to torque: tau_M = eta * N * k_t * i_tot.
      J_M dw/dt = tau_M - T - B_M w.
      Cascade P / PI on the motor encoder: e = v_ref + K_pos (q_ref - u) - w,
      tau_M = K_d e + K_i xi, dxi/dt = e (frozen when saturated), |tau_M| <= 2.2e5 N m;
      K_d = 2*pi*3 * (J_M + I), K_i = K_d * 2*pi*3 / 5, K_pos = 2*pi*3 / 4.
      Load sharing: motor k carries share s_k of i_tot, s = (1/3)(1 + 0.03 z_k) normalised
      to sum 1 (drawn per seed).
    Thermal: motors C_w = 900 J/K, R_w = 0.8 ohm * (1 + 0.00393 (T_w - 20)), R_th = 0.35 K/W to the
      gearbox; gearbox C_j = 6.0e4 J/K, heated by |F v| + (1 - eta)|tau_M w| + motor heat flow,
      R_j = 0.05 K/W to ambient 22 degC. Motors start 3 degC above the gearbox.
    Load: dynamometer, torque-controlled: set point tau_cmd -> rate limit 30 kN m/s -> two
      cascaded first-order lags of 0.08 s each = tau_L (the true load). Sign: tau_cmd =
      direction * profile (the dynamometer resists the commanded sense of motion).

Integrator: implicit trapezoid (Crank-Nicolson) with a simplified Newton (finite-difference
Jacobian frozen per step), fixed step h = 1/(fs*m) with m = ceil((1/fs) / 1 ms), so h <= 1 ms and
every sample falls on a node; the friction mode (stick/slip, sign) is fixed at the step start;
rate-independent states (hysteresis) are updated after each step from the step's twist increment.

Schemes (phase names from core.channels):
    1: idle 2 s; per period: load ramp 0 -> 120 kN m in 8 s ("load"), unload in 8 s ("unload");
       idle 1 s. Motor speed reference direction * rpm (ramped in 1 s).
    2: idle 2 s; per period 12 x (ramp +10 kN m in 0.5 s "load", hold 2 s "hold"), unload ramp 4 s;
       idle 1 s.
    (Schemes 1-2: if the reference position reaches +-170 deg the speed reference reverses
     through a 2 s ramp; only long runs at 3000 r/min reach it.)
    3: idle 1 s; fifth-order Fourier excitation (Eq. 12), period 12 s, a = (0.6,-0.3,0.25,-0.15,
       a5) with a5 = -sum(a1..a4), b = (0.2,0.35,-0.2,0.1,-0.12), scaled to a peak speed of
       0.026 rad/s, times direction, q(0)=0; "excite"; dynamometer at 0; idle 1 s.

Sensors (readings from the integrator nodes at the sample instants; noise rng
default_rng([seed, run, 7])):
    q        output absolute encoder, round to encoder_res_deg (default 0.01 deg).
    u        motor encoder motor_cpr counts/motor rev (default 2**17): step 2 pi/(cpr N) rad.
    torsion  q - u of those readings.
    torque   strain-gauge transducer: T -> two cascaded discrete first-order sections with DC group
             delay torque_lag_s in total -> + N(0, torque_noise) -> + bench offset.
    torque_load  load cell: tau_L + N(0, load_noise) (default 250 N m), no lag.
    torque_cmd   the dynamometer set point (exact).
    i_m1..3  s_k i_tot + N(0, current_noise) (default 0.01 A).
    w_m1..3  N w + N(0, speed_noise) (default 0.02 rad/s).
    temps    + N(0, 0.03) rounded to temp_res (default 0.1 degC).

Bench imperfection stated here (in the vocabulary): the torque transducer reads +35 N m at zero
torque (residual zero offset after tare) -> UNSTATED_VOCABULARY["torque_offset"].

Effects (scale s >= 0, scale 1 = the "typical" size; all vanish exactly at s = 0):
    stribeck: extra Coulomb s*0.15*f_c*phi(|v|/v_s), v_s = 3e-3 rad/s; phi: exp1 e^-x,
        exp2 e^-x^2, lorentzian 1/(1+x^2), hyperbolic 1/(1+x). Raises the breakaway F_s too.
    load_dependent_friction (mu = 0.004, T_r = 120e3): coulomb: +s mu |T|; coulomb_viscous:
        +s mu |T| and viscous f_v * s*0.2*|T|/T_r; power_flow: +s mu |T| when T v > 0,
        +s 0.4 mu |T| when back-driven.
    temperature_friction (dT = Tj - 25): coulomb_additive: Coulomb -s*5 N m/K * dT;
        viscous_exp: viscous f_v * s*(exp(-0.02 dT) - 1); both_linear: Coulomb and viscous
        times s*0.004*(-dT); coulomb_exp: Coulomb f_c * s*(exp(-0.004 dT) - 1).
    gear_ripple (Z = 36 per output rev): output_harmonics: torque s*150*(sin Zq + 0.5 sin(2Zq+0.7))
        on the output; motor_angle: kinematic error s*1.5e-5 rad * sin(2 N u) in the twist;
        load_modulated: torque s*150*(0.2 + 1.6|T|/T_r) sin(Zq); transmission_error:
        kinematic error s*1.5e-5 * sin(Zq + 0.3) in the twist.
    torque_offset (transducer): constant s*300 N m; linear_drift s*(50 + 5 t); settling
        s*400*(1 - exp(-t/20)).
    time_delay: extra pure delay s*20 ms of the torque reading (torque), of the output encoder
        (output_encoder) or of the motor encoder (motor_encoder).
    hysteresis (transmission torque s*1200 N m * z, twist scale delta = 3e-4 rad):
        bouc_wen_n1 dz = dD/delta (1 - (0.5 sgn(dD z) + 0.5)|z|); bouc_wen_n2 same with z^2;
        dahl dz = dD/delta (1 - z sgn dD); elastoplastic z = clamp(z + dD/delta, -1, 1).
    backlash (half gap g = s*1.745e-4 rad, i.e. total 0.02 deg at s = 1) on the twist:
        sharp dead zone; smooth (softplus, width g/4); load_closing: g/(1 + |tau_L|/30e3).
    asymmetric_friction: coulomb +s*0.08 f_c for v > 0; viscous +s*0.15 f_v for v < 0;
        both; bias: a constant s*180 N m friction torque.
  Out of vocabulary:
    periodic_disturbance: sine s*200 sin(2 pi 1.7 t) on the output; two_tone
        s*200*(0.7 sin(2 pi 1.7 t) + 0.5 sin(2 pi 4.59 t + 1)).
    position_dependent_stiffness: K * (1 + s*0.1 cos 2q) (cos2q); K * (1 + s*0.1 q/pi) (linear).
    encoder_drift: output reading + s*2e-5 rad/s * t (linear); + s*5e-4 sin(2 pi t/40) (wander).
    second_resonance: a body J2 = s*J20 on a spring k2 = J2 w2^2, damping 2 zeta w2 J2:
        output_mode (J20 = 0.05 I, 14 Hz, zeta 0.03, attached to q);
        motor_mode (J20 = 0.02 J_M, 30 Hz, zeta 0.05, attached to u).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, asdict, field
from typing import Any

import numba
import numpy as np
import pandas as pd

RIG_NAME = "rig_z"
REDUCTION = 11000.0
SEED_IS_CAMPAIGN = True
SCALE_MAX = 10.0

EFFECT_FORMS: dict[str, tuple[str, ...]] = {
    "stribeck": ("exp1", "exp2", "lorentzian", "hyperbolic"),
    "load_dependent_friction": ("coulomb", "coulomb_viscous", "power_flow"),
    "temperature_friction": ("coulomb_additive", "viscous_exp", "both_linear", "coulomb_exp"),
    "gear_ripple": ("output_harmonics", "motor_angle", "load_modulated", "transmission_error"),
    "torque_offset": ("constant", "linear_drift", "settling"),
    "time_delay": ("torque", "output_encoder", "motor_encoder"),
    "hysteresis": ("bouc_wen_n1", "bouc_wen_n2", "dahl", "elastoplastic"),
    "backlash": ("sharp", "smooth", "load_closing"),
    "asymmetric_friction": ("coulomb", "viscous", "both", "bias"),
    "periodic_disturbance": ("sine", "two_tone"),
    "position_dependent_stiffness": ("cos2q", "linear"),
    "encoder_drift": ("linear", "wander"),
    "second_resonance": ("output_mode", "motor_mode"),
}
OUT_OF_VOCABULARY: tuple[str, ...] = ("periodic_disturbance", "position_dependent_stiffness",
                                      "encoder_drift", "second_resonance")
UNSTATED_VOCABULARY: dict[str, str] = {
    "torque_offset": "the torque transducer reads +35 N·m at zero torque (zero offset left "
                     "after tare, inside its calibration tolerance), constant",
}
BENCH_TORQUE_OFFSET = 35.0

_EFFECT_IDS = {name: i for i, name in enumerate(EFFECT_FORMS)}
N_EFFECTS = len(EFFECT_FORMS)

TABLE3 = {"I": 6685.166, "mr_x": 20.779, "mr_y": -34.543, "f_v": 8683.272, "f_c": 2352.660}
G = 9.81
RATED = 120e3
TWIST_RATED = math.radians(0.5)
B_STIFF = math.log(1.6) / TWIST_RATED
K0 = RATED * B_STIFF / 0.6
SPREAD = {"I": 0.02, "mr_x": 0.02, "mr_y": 0.02, "f_v": 0.02, "f_c": 0.02, "K": 0.03,
          "D_t": 0.03, "k_t": 0.02}
V_BAND = 3e-4

# parameter vector indices (module constants, frozen by numba)
P_I, P_MRX, P_MRY, P_FV, P_FC, P_K, P_B, P_DT, P_JM, P_BM, P_KD, P_KI, P_KPOS, P_TMAX, \
    P_ETA, P_N, P_G, P_VB, P_KT, P_RW, P_CW, P_RTH, P_CJ, P_RJ, P_TAMB = range(25)
N_P = 25


# --------------------------------------------------------------------------- sensors
@dataclass
class SensorSpec:
    sample_rate_hz: float = 1000.0
    encoder_res_deg: float = 0.01
    torque_noise: float = 150.0
    torque_lag_s: float = 0.0
    motor_cpr: float = 131072.0
    load_noise: float = 250.0
    current_noise: float = 0.01
    speed_noise: float = 0.02
    temp_res: float = 0.1

    _RANGES = {"sample_rate_hz": (10.0, 1000.0), "encoder_res_deg": (1e-5, 1.0),
               "torque_noise": (0.0, 1e4), "torque_lag_s": (0.0, 0.5),
               "motor_cpr": (16.0, 2.0 ** 24), "load_noise": (0.0, 1e4),
               "current_noise": (0.0, 10.0), "speed_noise": (0.0, 100.0),
               "temp_res": (0.0, 5.0)}

    def __post_init__(self):
        for name, (lo, hi) in self._RANGES.items():
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, float, np.floating, np.integer)):
                raise ValueError(f"{name}: expected a number, got {v!r}")
            v = float(v)
            if not math.isfinite(v) or v < lo or v > hi:
                raise ValueError(f"{name}: {v!r} outside [{lo}, {hi}]")
            setattr(self, name, v)




@dataclass
class RigRun:
    samples: pd.DataFrame
    meta: dict
    truth: pd.DataFrame
    params: dict


# --------------------------------------------------------------------------- machine
def draw_machine(seed: int) -> dict[str, Any]:
    rng = np.random.default_rng([int(seed), 20240611])
    z = np.clip(rng.standard_normal(12), -2.5, 2.5)
    m = {k: TABLE3[k] * (1 + SPREAD[k] * z[i]) for i, k in enumerate(TABLE3)}
    m["K"] = K0 * (1 + SPREAD["K"] * z[5])
    m["D_t"] = 5.4e4 * (1 + SPREAD["D_t"] * z[6])
    m["k_t"] = 0.9 * (1 + SPREAD["k_t"] * z[7])
    sh = (1 + 0.03 * z[8:11]) / 3.0
    m["shares"] = [float(x) for x in sh / sh.sum()]
    m["b_stiff"] = B_STIFF
    m["J_M"] = 3 * 1.2e-3 * REDUCTION ** 2
    m["B_M"] = 2.0e4
    m["eta"] = 0.92
    return {k: (float(v) if not isinstance(v, list) else v) for k, v in m.items()}


def _pvec(m: dict) -> np.ndarray:
    p = np.zeros(N_P)
    wc = 2 * math.pi * 3.0
    p[P_I], p[P_MRX], p[P_MRY], p[P_FV], p[P_FC] = m["I"], m["mr_x"], m["mr_y"], m["f_v"], m["f_c"]
    p[P_K], p[P_B], p[P_DT], p[P_JM], p[P_BM] = m["K"], m["b_stiff"], m["D_t"], m["J_M"], m["B_M"]
    p[P_KD] = wc * (m["J_M"] + m["I"])
    p[P_KI] = p[P_KD] * wc / 5
    p[P_KPOS] = wc / 4
    p[P_TMAX] = 2.2e5
    p[P_ETA], p[P_N], p[P_G], p[P_VB], p[P_KT] = m["eta"], REDUCTION, G, V_BAND, m["k_t"]
    p[P_RW], p[P_CW], p[P_RTH], p[P_CJ], p[P_RJ], p[P_TAMB] = 0.8, 900.0, 0.35, 6.0e4, 0.05, 22.0
    return p


# --------------------------------------------------------------------------- kernel
E_STR, E_LDF, E_TMP, E_RIP, E_OFF, E_DLY, E_HYS, E_BKL, E_ASY, E_PER, E_PDS, E_ENC, E_SEC = range(13)


@numba.njit(cache=True)
def _softplus(x):
    return max(x, 0.0) + math.log1p(math.exp(-abs(x)))


@numba.njit(cache=True)
def _coulomb_viscous(p, fo, fs, sig, v, T, Tj):
    """Coulomb level C (>= 0), viscous coefficient V and a bias torque for sign sig."""
    C = p[P_FC]
    V = p[P_FV]
    bias = 0.0
    s = fs[E_STR]
    if fo[E_STR] >= 0 and s > 0:
        x = abs(v) / 3e-3
        f = fo[E_STR]
        if f == 0:
            ph = math.exp(-x)
        elif f == 1:
            ph = math.exp(-x * x)
        elif f == 2:
            ph = 1.0 / (1.0 + x * x)
        else:
            ph = 1.0 / (1.0 + x)
        C += s * 0.15 * p[P_FC] * ph
    s = fs[E_LDF]
    if fo[E_LDF] >= 0 and s > 0:
        mu = 0.004
        f = fo[E_LDF]
        if f == 0:
            C += s * mu * abs(T)
        elif f == 1:
            C += s * mu * abs(T)
            V += p[P_FV] * s * 0.2 * abs(T) / 120e3
        else:
            C += s * mu * abs(T) * (1.0 if T * sig > 0 else 0.4)
    s = fs[E_TMP]
    if fo[E_TMP] >= 0 and s > 0:
        dT = Tj - 25.0
        f = fo[E_TMP]
        if f == 0:
            C += -s * 5.0 * dT
        elif f == 1:
            V += p[P_FV] * s * (math.exp(-0.02 * dT) - 1.0)
        elif f == 2:
            C += p[P_FC] * s * 0.004 * (-dT)
            V += p[P_FV] * s * 0.004 * (-dT)
        else:
            C += p[P_FC] * s * (math.exp(-0.004 * dT) - 1.0)
    s = fs[E_ASY]
    if fo[E_ASY] >= 0 and s > 0:
        f = fo[E_ASY]
        if (f == 0 or f == 2) and sig > 0:
            C += s * 0.08 * p[P_FC]
        if (f == 1 or f == 2) and sig < 0:
            V += s * 0.15 * p[P_FV]
        if f == 3:
            bias = s * 180.0
    C = max(C, 0.02 * p[P_FC])
    V = max(V, 0.0)
    return C, V, bias


@numba.njit(cache=True)
def _deadzone(d, fo, fs, tauL):
    if fo[E_BKL] < 0 or fs[E_BKL] <= 0:
        return d
    g = fs[E_BKL] * 1.745e-4
    f = fo[E_BKL]
    if f == 2:
        g = g / (1.0 + abs(tauL) / 30e3)
    if f == 1:
        eps = g / 4.0
        return eps * (_softplus((d - g) / eps) - _softplus((-d - g) / eps))
    if d > g:
        return d - g
    if d < -g:
        return d + g
    return 0.0


@numba.njit(cache=True)
def _torque(p, fo, fs, q, v, u, w, tauL, Tj, z):
    """Transmitted torque T."""
    d = u - q
    s = fs[E_RIP]
    if fo[E_RIP] == 1 and s > 0:
        d += s * 1.5e-5 * math.sin(2.0 * p[P_N] * u)
    elif fo[E_RIP] == 3 and s > 0:
        d += s * 1.5e-5 * math.sin(36.0 * q + 0.3)
    d = _deadzone(d, fo, fs, tauL)
    K = p[P_K] * (1.0 - 1.5e-3 * (Tj - 20.0))
    s = fs[E_PDS]
    if fo[E_PDS] == 0 and s > 0:
        K *= 1.0 + s * 0.1 * math.cos(2.0 * q)
    elif fo[E_PDS] == 1 and s > 0:
        K *= 1.0 + s * 0.1 * q / math.pi
    b = p[P_B]
    ad = abs(d)
    tel = K / b * math.expm1(b * ad)
    if d < 0:
        tel = -tel
    T = tel + p[P_DT] * (w - v)
    if fo[E_HYS] >= 0 and fs[E_HYS] > 0:
        T += fs[E_HYS] * 1200.0 * z
    return T


@numba.njit(cache=True)
def _out_extra(p, fo, fs, q, T, t):
    """Torques on the output other than T, load, gravity, friction (ripple, disturbance)."""
    e = 0.0
    s = fs[E_RIP]
    if s > 0:
        if fo[E_RIP] == 0:
            e += s * 150.0 * (math.sin(36.0 * q) + 0.5 * math.sin(72.0 * q + 0.7))
        elif fo[E_RIP] == 2:
            e += s * 150.0 * (0.2 + 1.6 * abs(T) / 120e3) * math.sin(36.0 * q)
    s = fs[E_PER]
    if s > 0:
        w1 = 2.0 * math.pi * 1.7
        if fo[E_PER] == 0:
            e += s * 200.0 * math.sin(w1 * t)
        elif fo[E_PER] == 1:
            e += s * 200.0 * (0.7 * math.sin(w1 * t) + 0.5 * math.sin(2.7 * w1 * t + 1.0))
    return e


@numba.njit(cache=True)
def _rhs(p, fo, fs, x, t, qref, vref, tauL, Tj, z, stick, sig, out):
    q, v, u, w, xi, y2, v2 = x[0], x[1], x[2], x[3], x[4], x[5], x[6]
    if stick:
        v = 0.0
    T = _torque(p, fo, fs, q, v, u, w, tauL, Tj, z)
    grav = p[P_G] * (p[P_MRX] * math.sin(q) + p[P_MRY] * math.cos(q))
    extra = _out_extra(p, fo, fs, q, T, t)
    # second mode
    c_out = 0.0
    c_mot = 0.0
    a2 = 0.0
    if fo[E_SEC] >= 0 and fs[E_SEC] > 0:
        if fo[E_SEC] == 0:
            J2 = fs[E_SEC] * 0.05 * p[P_I]
            w2 = 2.0 * math.pi * 14.0
            zt = 0.03
            f2 = J2 * w2 * w2 * (q - y2) + 2.0 * zt * w2 * J2 * (v - v2)
            c_out = f2
        else:
            J2 = fs[E_SEC] * 0.02 * p[P_JM]
            w2 = 2.0 * math.pi * 30.0
            zt = 0.05
            f2 = J2 * w2 * w2 * (u - y2) + 2.0 * zt * w2 * J2 * (w - v2)
            c_mot = f2
        a2 = f2 / J2
    # drive
    e = vref + p[P_KPOS] * (qref - u) - w
    tm = p[P_KD] * e + p[P_KI] * xi
    sat = False
    if tm > p[P_TMAX]:
        tm = p[P_TMAX]
        sat = True
    elif tm < -p[P_TMAX]:
        tm = -p[P_TMAX]
        sat = True
    out[0] = v
    fext = T - tauL - grav + extra - c_out
    if stick:
        out[1] = 0.0
        fr = fext
    else:
        C, V, bias = _coulomb_viscous(p, fo, fs, sig, v, T, Tj)
        fr = sig * C + V * v + bias
        out[1] = (fext - fr) / p[P_I]
    out[2] = w
    out[3] = (tm - T - p[P_BM] * w - c_mot) / p[P_JM]
    out[4] = 0.0 if sat else e
    out[5] = v2
    out[6] = a2
    return T, fr, tm


@numba.njit(cache=True)
def _hyst_update(form, z, dd):
    delta = 3e-4
    n = int(abs(dd) / delta * 8.0) + 1
    step = dd / n / delta
    for _ in range(n):
        if form == 0:
            sgn = 1.0 if step * z >= 0 else -1.0
            z += step * (1.0 - (0.5 * sgn + 0.5) * abs(z))
        elif form == 1:
            sgn = 1.0 if step * z >= 0 else -1.0
            z += step * (1.0 - (0.5 * sgn + 0.5) * z * z)
        elif form == 2:
            sd = 1.0 if step >= 0 else -1.0
            z += step * (1.0 - z * sd)
        else:
            z = min(1.0, max(-1.0, z + step))
    return z


@numba.njit(cache=True)
def _simulate(h, qref, vref, tauL, p, fo, fs, Tj0, Tm0, shares):
    n = qref.shape[0]
    nx = 7
    X = np.zeros((n, nx))
    Tr = np.zeros(n)
    Fr = np.zeros(n)
    Acc = np.zeros(n)
    Itot = np.zeros(n)
    Stick = np.zeros(n)
    TJ = np.zeros(n)
    TM = np.zeros((n, 3))
    Zs = np.zeros(n)
    x = np.zeros(nx)
    f0 = np.zeros(nx)
    f1 = np.zeros(nx)
    fp = np.zeros(nx)
    xp = np.zeros(nx)
    Jm = np.zeros((nx, nx))
    Tj = Tj0
    tm_w = np.empty(3)
    for k in range(3):
        tm_w[k] = Tm0
    z = 0.0
    ktn = p[P_ETA] * p[P_N] * p[P_KT]
    # initial outputs
    T, fr, tm = _rhs(p, fo, fs, x, 0.0, qref[0], vref[0], tauL[0], Tj, z, True, 1.0, f0)
    Tr[0] = T
    Fr[0] = fr
    Stick[0] = 1.0
    TJ[0] = Tj
    for k in range(3):
        TM[0, k] = tm_w[k]
    Itot[0] = tm / ktn
    for i in range(n - 1):
        t0 = i * h
        t1 = t0 + h
        # friction mode at step start
        T0 = _torque(p, fo, fs, x[0], x[1], x[2], x[3], tauL[i], Tj, z)
        grav = p[P_G] * (p[P_MRX] * math.sin(x[0]) + p[P_MRY] * math.cos(x[0]))
        fext = T0 - tauL[i] - grav + _out_extra(p, fo, fs, x[0], T0, t0)
        if fo[E_SEC] == 0 and fs[E_SEC] > 0:
            J2 = fs[E_SEC] * 0.05 * p[P_I]
            w2 = 2.0 * math.pi * 14.0
            fext -= J2 * w2 * w2 * (x[0] - x[5]) + 2.0 * 0.03 * w2 * J2 * (x[1] - x[6])
        stick = False
        sig = 1.0
        if abs(x[1]) < p[P_VB]:
            sig = 1.0 if fext >= 0 else -1.0
            C, V, bias = _coulomb_viscous(p, fo, fs, sig, 0.0, T0, Tj)
            if abs(fext - bias) <= C:
                stick = True
                x[1] = 0.0
        else:
            sig = 1.0 if x[1] > 0 else -1.0
        _rhs(p, fo, fs, x, t0, qref[i], vref[i], tauL[i], Tj, z, stick, sig, f0)
        # predictor (explicit Euler) and frozen Jacobian
        for j in range(nx):
            xp[j] = x[j] + h * f0[j]
        _rhs(p, fo, fs, xp, t1, qref[i + 1], vref[i + 1], tauL[i + 1], Tj, z, stick, sig, f1)
        for j in range(nx):
            dx = 1e-7 * (abs(xp[j]) + 1e-3)
            xp[j] += dx
            _rhs(p, fo, fs, xp, t1, qref[i + 1], vref[i + 1], tauL[i + 1], Tj, z, stick, sig, fp)
            xp[j] -= dx
            for r in range(nx):
                Jm[r, j] = -0.5 * h * (fp[r] - f1[r]) / dx
            Jm[j, j] += 1.0
        x1 = xp.copy()
        for it in range(10):
            _rhs(p, fo, fs, x1, t1, qref[i + 1], vref[i + 1], tauL[i + 1], Tj, z, stick, sig, f1)
            res = np.empty(nx)
            for j in range(nx):
                res[j] = x1[j] - x[j] - 0.5 * h * (f0[j] + f1[j])
            dxs = np.linalg.solve(Jm, res)
            err = 0.0
            for j in range(nx):
                x1[j] -= dxs[j]
                err = max(err, abs(dxs[j]) / (abs(x1[j]) + 1e-4))
            if err < 1e-10:
                break
        if stick:
            x1[1] = 0.0
            x1[0] = x[0]
        # hysteresis state from the step's twist increment
        if fo[E_HYS] >= 0 and fs[E_HYS] > 0:
            z = _hyst_update(fo[E_HYS], z, (x1[2] - x1[0]) - (x[2] - x[0]))
        for j in range(nx):
            x[j] = x1[j]
        T, fr, tm = _rhs(p, fo, fs, x, t1, qref[i + 1], vref[i + 1], tauL[i + 1], Tj, z,
                         stick, sig, f1)
        itot = tm / ktn
        # thermal (explicit)
        qflow = 0.0
        for k in range(3):
            ik = shares[k] * itot
            rw = p[P_RW] * (1.0 + 0.00393 * (tm_w[k] - 20.0))
            qk = (tm_w[k] - Tj) / p[P_RTH]
            tm_w[k] += h * (rw * ik * ik - qk) / p[P_CW]
            qflow += qk
        pj = abs(fr * x[1]) + (1.0 - p[P_ETA]) * abs(tm * x[3]) + qflow
        Tj += h * (pj - (Tj - p[P_TAMB]) / p[P_RJ]) / p[P_CJ]
        X[i + 1] = x
        Tr[i + 1] = T
        Fr[i + 1] = fr
        Acc[i + 1] = f1[1]
        Itot[i + 1] = itot
        Stick[i + 1] = 1.0 if stick else 0.0
        TJ[i + 1] = Tj
        for k in range(3):
            TM[i + 1, k] = tm_w[k]
        Zs[i + 1] = z
    return X, Tr, Fr, Acc, Itot, Stick, TJ, TM, Zs


# --------------------------------------------------------------------------- schemes
_FOURIER_A = np.array([0.6, -0.3, 0.25, -0.15, 0.0])
_FOURIER_A[4] = -_FOURIER_A[:4].sum()
_FOURIER_B = np.array([0.2, 0.35, -0.2, 0.1, -0.12])
T_FOURIER = 12.0
V_PEAK_FOURIER = 0.026


def _profile(scheme: int, periods: int):
    """(segments) list of (duration, start value, end value, phase) for the load set point."""
    seg = []
    if scheme == 1:
        seg.append((2.0, 0.0, 0.0, "idle"))
        for _ in range(periods):
            seg.append((8.0, 0.0, RATED, "load"))
            seg.append((8.0, RATED, 0.0, "unload"))
        seg.append((1.0, 0.0, 0.0, "idle"))
    elif scheme == 2:
        seg.append((2.0, 0.0, 0.0, "idle"))
        for _ in range(periods):
            for k in range(12):
                seg.append((0.5, k * 10e3, (k + 1) * 10e3, "load"))
                seg.append((2.0, (k + 1) * 10e3, (k + 1) * 10e3, "hold"))
            seg.append((4.0, RATED, 0.0, "unload"))
        seg.append((1.0, 0.0, 0.0, "idle"))
    else:
        seg.append((1.0, 0.0, 0.0, "idle"))
        seg.append((T_FOURIER * periods, 0.0, 0.0, "excite"))
        seg.append((1.0, 0.0, 0.0, "idle"))
    return seg


def _fourier(t, direction):
    wf = 2 * math.pi / T_FOURIER
    l = np.arange(1, 6)
    tt = np.linspace(0, T_FOURIER, 4001)
    vv = (_FOURIER_A[:, None] * np.cos(wf * l[:, None] * tt) +
          _FOURIER_B[:, None] * np.sin(wf * l[:, None] * tt)).sum(0)
    c = V_PEAK_FOURIER / np.abs(vv).max()
    a, b = _FOURIER_A * c, _FOURIER_B * c
    q0 = (b / (wf * l)).sum()
    arg = wf * l[:, None] * t[None, :]
    q = (a[:, None] / (wf * l[:, None]) * np.sin(arg) - b[:, None] / (wf * l[:, None]) * np.cos(arg)).sum(0) + q0
    v = (a[:, None] * np.cos(arg) + b[:, None] * np.sin(arg)).sum(0)
    return direction * q, direction * v


def _references(scheme, rpm, direction, periods, tgrid, seg):
    n = len(tgrid)
    h = tgrid[1] - tgrid[0]
    cmd = np.zeros(n)
    phase_idx = np.zeros(n, dtype=np.int64)
    names = []
    t0 = 0.0
    for k, (d, a, b, ph) in enumerate(seg):
        m = (tgrid >= t0 - 1e-12) & (tgrid < t0 + d - 1e-12)
        cmd[m] = a + (b - a) * (tgrid[m] - t0) / d
        phase_idx[m] = k
        names.append(ph)
        t0 += d
    phase_idx[tgrid >= t0 - 1e-12] = len(seg) - 1
    if scheme in (1, 2):
        cmd = direction * cmd
        w_out = rpm * 2 * math.pi / 60 / REDUCTION
        vref = np.zeros(n)
        qref = np.zeros(n)
        sense = float(direction)
        target = sense
        vcur = 0.0
        qcur = 0.0
        lim = math.radians(170.0)
        ramp_in = w_out / 1.0
        ramp_rev = w_out / 1.0  # full speed to zero in 1 s, i.e. 2 s through a reversal
        for i in range(n):
            if qcur * target >= lim:
                target = -target
            goal = target * w_out
            rate = ramp_in if tgrid[i] < 1.0 else ramp_rev
            dv = goal - vcur
            vcur += max(-rate * h, min(rate * h, dv))
            vref[i] = vcur
            qref[i] = qcur
            qcur += vcur * h
    else:
        qref = np.zeros(n)
        vref = np.zeros(n)
        m = np.array([names[k] == "excite" for k in phase_idx])
        te = tgrid[m] - 1.0
        qref[m], vref[m] = _fourier(te, direction)
        after = tgrid >= 1.0 + T_FOURIER * periods
        qref[after] = qref[m][-1] if m.any() else 0.0
    return cmd, qref, vref, phase_idx, names


def _dyno(cmd, h):
    n = len(cmd)
    out = np.zeros(n)
    r = 0.0
    y1 = 0.0
    y2 = 0.0
    a = math.exp(-h / 0.08)
    rl = 30e3 * h
    for i in range(n):
        r += max(-rl, min(rl, cmd[i] - r))
        y1 = a * y1 + (1 - a) * r
        y2 = a * y2 + (1 - a) * y1
        out[i] = y2
    return out


def _delay(t, sig, d):
    if d <= 0:
        return sig
    return np.interp(t - d, t, sig, left=sig[0])


# --------------------------------------------------------------------------- public
def _check_effects(effects):
    fo = -np.ones(N_EFFECTS, dtype=np.int64)
    fs = np.zeros(N_EFFECTS)
    clean = {}
    for name, spec in (effects or {}).items():
        if name not in EFFECT_FORMS:
            raise ValueError(f"unknown effect {name!r}; known: {sorted(EFFECT_FORMS)}")
        if not isinstance(spec, dict) or "form" not in spec:
            raise ValueError(f"effect {name!r}: expected {{'form': ..., 'scale': ...}}")
        form = spec["form"]
        if form not in EFFECT_FORMS[name]:
            raise ValueError(f"effect {name!r}: unknown form {form!r}; known: {EFFECT_FORMS[name]}")
        scale = spec.get("scale", 1.0)
        if isinstance(scale, bool) or not isinstance(scale, (int, float, np.floating, np.integer)):
            raise ValueError(f"effect {name!r}: scale must be a number, got {scale!r}")
        scale = float(scale)
        if not math.isfinite(scale) or scale < 0 or scale > SCALE_MAX:
            raise ValueError(f"effect {name!r}: scale {scale!r} outside [0, {SCALE_MAX}]")
        i = _EFFECT_IDS[name]
        fo[i] = EFFECT_FORMS[name].index(form)
        fs[i] = scale
        clean[name] = {"form": form, "scale": scale}
    return fo, fs, clean


def simulate_run(scheme: int, motor_speed_rpm: float | None, direction: int, temp_joint_c: float,
                 effects: dict[str, dict] | None = None, *, sensors: SensorSpec | None = None,
                 periods: int = 3, seed: int, run: int) -> RigRun:
    if scheme not in (1, 2, 3) or isinstance(scheme, bool):
        raise ValueError(f"scheme: expected 1, 2 or 3, got {scheme!r}")
    if scheme == 3:
        if motor_speed_rpm is not None:
            raise ValueError("motor_speed_rpm: must be None for scheme 3")
    else:
        if motor_speed_rpm not in (300, 3000, 300.0, 3000.0) or isinstance(motor_speed_rpm, bool):
            raise ValueError(f"motor_speed_rpm: expected 300 or 3000, got {motor_speed_rpm!r}")
    if direction not in (1, -1) or isinstance(direction, bool):
        raise ValueError(f"direction: expected +1 or -1, got {direction!r}")
    if (isinstance(temp_joint_c, bool) or not isinstance(temp_joint_c, (int, float, np.floating))
            or not math.isfinite(temp_joint_c) or not 15.0 <= temp_joint_c <= 60.0):
        raise ValueError(f"temp_joint_c: expected 15..60 degC, got {temp_joint_c!r}")
    if isinstance(periods, bool) or not isinstance(periods, (int, np.integer)) or not 1 <= periods <= 20:
        raise ValueError(f"periods: expected an integer 1..20, got {periods!r}")
    for nm, val in (("seed", seed), ("run", run)):
        if isinstance(val, bool) or not isinstance(val, (int, np.integer)) or val < 0:
            raise ValueError(f"{nm}: expected an integer >= 0, got {val!r}")
    if sensors is None:
        sensors = SensorSpec()
    elif not isinstance(sensors, SensorSpec):
        raise ValueError(f"sensors: expected a SensorSpec, got {type(sensors).__name__}")
    else:
        sensors.__post_init__()
    fo, fs, clean = _check_effects(effects)

    machine = draw_machine(seed)
    p = _pvec(machine)
    fsr = sensors.sample_rate_hz
    msub = max(1, int(math.ceil((1.0 / fsr) / 1e-3 - 1e-9)))
    h = 1.0 / (fsr * msub)
    seg = _profile(scheme, int(periods))
    duration = sum(s[0] for s in seg)
    nsamp = int(math.floor(duration * fsr + 1e-9)) + 1
    ngrid = (nsamp - 1) * msub + 1
    tgrid = np.arange(ngrid) * h
    rpm = 0.0 if motor_speed_rpm is None else float(motor_speed_rpm)
    cmd, qref, vref, phase_idx, names = _references(scheme, rpm, direction, periods, tgrid, seg)
    tauL = _dyno(cmd, h)
    X, Tr, Fr, Acc, Itot, Stick, TJ, TM, Zs = _simulate(
        h, qref, vref, tauL, p, fo, fs, float(temp_joint_c), float(temp_joint_c) + 3.0,
        np.array(machine["shares"]))

    idx = np.arange(nsamp) * msub
    t = tgrid[idx]
    rng = np.random.default_rng([int(seed), int(run), 7])
    N = REDUCTION
    q_true, u_true = X[:, 0], X[:, 2]
    # output encoder
    qg = q_true.copy()
    if fo[E_ENC] == 0:
        qg = qg + fs[E_ENC] * 2e-5 * tgrid
    elif fo[E_ENC] == 1:
        qg = qg + fs[E_ENC] * 5e-4 * np.sin(2 * math.pi * tgrid / 40.0)
    if fo[E_DLY] == 1:
        qg = _delay(tgrid, qg, fs[E_DLY] * 0.02)
    res_q = math.radians(sensors.encoder_res_deg)
    q_read = np.round(qg[idx] / res_q) * res_q
    ug = u_true
    if fo[E_DLY] == 2:
        ug = _delay(tgrid, ug, fs[E_DLY] * 0.02)
    res_u = 2 * math.pi / sensors.motor_cpr / N
    u_read = np.round(ug[idx] * N * sensors.motor_cpr / (2 * math.pi)) * (2 * math.pi / sensors.motor_cpr) / N
    # torque transducer
    tg = Tr
    if fo[E_DLY] == 0:
        tg = _delay(tgrid, tg, fs[E_DLY] * 0.02)
    if sensors.torque_lag_s > 0:
        L = sensors.torque_lag_s / (2 * h)
        a = L / (1 + L)
        from scipy.signal import lfilter
        zi = np.array([a * tg[0]])
        y1, _ = lfilter([1 - a], [1, -a], tg, zi=zi)
        y2, _ = lfilter([1 - a], [1, -a], y1, zi=np.array([a * tg[0]]))
        tg = y2
    off = np.full(nsamp, BENCH_TORQUE_OFFSET)
    if fo[E_OFF] == 0:
        off += fs[E_OFF] * 300.0
    elif fo[E_OFF] == 1:
        off += fs[E_OFF] * (50.0 + 5.0 * t)
    elif fo[E_OFF] == 2:
        off += fs[E_OFF] * 400.0 * (1 - np.exp(-t / 20.0))
    torque_read = tg[idx] + rng.standard_normal(nsamp) * sensors.torque_noise + off
    load_read = tauL[idx] + rng.standard_normal(nsamp) * sensors.load_noise
    cols: dict[str, Any] = {"t": t, "q": q_read, "u": u_read, "torsion": q_read - u_read,
                            "torque": torque_read, "torque_load": load_read, "torque_cmd": cmd[idx]}
    sh = machine["shares"]
    for k in range(3):
        cols[f"i_m{k + 1}"] = sh[k] * Itot[idx] + rng.standard_normal(nsamp) * sensors.current_noise
    for k in range(3):
        cols[f"w_m{k + 1}"] = N * X[idx, 3] + rng.standard_normal(nsamp) * sensors.speed_noise

    def _temp(x):
        y = x + rng.standard_normal(nsamp) * 0.03
        return np.round(y / sensors.temp_res) * sensors.temp_res if sensors.temp_res > 0 else y
    cols["temp_joint"] = _temp(TJ[idx])
    for k in range(3):
        cols[f"temp_m{k + 1}"] = _temp(TM[idx, k])
    cols["phase"] = np.array([names[i] for i in phase_idx[idx]], dtype=object)
    samples = pd.DataFrame(cols)

    truth = pd.DataFrame({
        "t": t, "q": q_true[idx], "qd": X[idx, 1], "qdd": Acc[idx], "u": u_true[idx],
        "ud": X[idx, 3], "twist": u_true[idx] - q_true[idx], "torque": Tr[idx],
        "torque_load": tauL[idx], "friction": Fr[idx],
        "gravity": G * (machine["mr_x"] * np.sin(q_true[idx]) + machine["mr_y"] * np.cos(q_true[idx])),
        "stick": Stick[idx], "temp_joint": TJ[idx], "hyst_z": Zs[idx],
    })
    meta = {
        "scheme": int(scheme), "motor_speed_rpm": None if motor_speed_rpm is None else float(motor_speed_rpm),
        "direction": int(direction), "reduction": REDUCTION, "rig": RIG_NAME, "source": "emulator",
        "sample_rate_hz": float(fsr), "started_at": "2026-01-01T00:00:00Z",
        "notes": f"rig_z validation run seed={seed} run={run}",
        "sensors": {
            "q": {"resolution": res_q, "noise_sd": 0.0, "lag_s": 0.0},
            "u": {"resolution": res_u, "noise_sd": 0.0, "lag_s": 0.0},
            "torque": {"resolution": 0.0, "noise_sd": float(sensors.torque_noise),
                       "lag_s": float(sensors.torque_lag_s)},
            "torque_load": {"resolution": 0.0, "noise_sd": float(sensors.load_noise), "lag_s": 0.0},
            "i_m1": {"noise_sd": float(sensors.current_noise)},
            "i_m2": {"noise_sd": float(sensors.current_noise)},
            "i_m3": {"noise_sd": float(sensors.current_noise)},
            "w_m1": {"noise_sd": float(sensors.speed_noise)},
            "w_m2": {"noise_sd": float(sensors.speed_noise)},
            "w_m3": {"noise_sd": float(sensors.speed_noise)},
            "temp_joint": {"resolution": float(sensors.temp_res), "noise_sd": 0.03},
        },
    }
    params = {"machine": machine, "effects": clean, "sensors": asdict(sensors), "seed": int(seed),
              "run": int(run), "scheme": int(scheme), "motor_speed_rpm": motor_speed_rpm,
              "direction": int(direction), "temp_joint_c": float(temp_joint_c),
              "periods": int(periods), "step_s": h, "substeps": msub, "duration_s": float(t[-1]),
              "bench_torque_offset": BENCH_TORQUE_OFFSET, "v_band": V_BAND}
    return RigRun(samples=samples, meta=meta, truth=truth, params=params)
