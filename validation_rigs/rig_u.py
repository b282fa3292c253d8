"""Rig U: an independent physics model of the CFETR CMOR joint-4 test bench (validation rig).

Written from the paper (shared/seeds/cmor-sghmc-paper.txt) and shared/docs only, sharing no code
or modelling choice with the project's simulators. It produces runs in the run format
(core.runfile) plus the true states, to score a sim-to-real diagnosis blind.

Data sheet
==========

Machine (per campaign: `seed` draws it, every run of that seed uses the same machine)
-----------------------------------------------------------------------------------
Output body (paper Eq. 4 plus the loading shaft), q the output angle [rad]:

    I*q'' = T - tau_L - g*(mr_x*sin q + mr_y*cos q) - F_gms + tau_x

  nominal Table 3 (LS column) with a small campaign spread (normal, clipped at 2 sd):
  I = 6685.166 kg m^2 (sd 0.4 %), mr_x = 20.779 kg m (sd 2 %), mr_y = -34.543 kg m (sd 2 %),
  f_v = 8683.272 N m s/rad (sd 0.15 %), f_c = 2352.66 N m (sd 0.3 %), g = 9.81 m/s^2.
  tau_x collects the effects' torques on the output (ripple, periodic disturbance) and is 0
  nominally.

Friction F_gms: generalized Maxwell-slip (GMS), 4 elements i with weights
  alpha = (0.40, 0.30, 0.20, 0.10) (sum 1), break-away displacements
  zeta = (4e-5, 8e-5, 1.5e-4, 3e-4) rad, element stiffness kappa_i = alpha_i*f_c/zeta_i:

    F_gms = sum_i kappa_i*z_i + f_v*q'
    r_i = kappa_i*z_i / (alpha_i*s(q'))                      (load ratio of element i)
    z_i' = q'                               if q'*z_i <= 0 or |r_i| < 1-delta   (stuck)
    z_i' = q'*(1-|r_i|)/delta               if q'*z_i > 0 and 1-delta <= |r_i| <= 1
    z_i' = sgn(z_i)*C*(1-|r_i|)             if q'*z_i > 0 and |r_i| > 1  (slipping, GMS rate C)
  delta = 0.2 (a regularised yield band so the integrator never chatters), C = 0.02 rad/s.
  The sliding limit s(v) is f_c nominally, so in steady sliding F_gms = f_c*sgn(q') + f_v*q',
  i.e. Eq. 4 with Table 3. Effects change s(v) and the viscous slope (below).

Transmission (3 motors -> shared first stage -> main stage, total N = 11000 = n1*n2, n1 = 10):
  motor k (k = 1..3): rotor J_m,k = 0.020 kg m^2 (+-3 % per campaign), torque k_t*i_k
  (k_t = 1.30 N m/A), viscous b_m = 2e-4 N m s/rad, current loop first order (tau_c = 2 ms)
  limited at its own i_max,k = 15 A (+-5 %). Mesh of motor k into the first stage (motor side):
      M_k = k_mesh*(theta_k - n1*phi) + c_mesh*(omega_k - n1*phi'),  k_mesh = 5000 N m/rad,
      c_mesh = 2 N m s/rad.
  First stage (inertia J_1 = 2 kg m^2 at phi):  J_1*phi'' = n1*sum_k M_k - T/n2.
  Main stage twist Delta = phi/n2 - q; transmitted torque, two-slope law softer near zero:
      K(D) = k1*D                          for |D| <= d_b
      K(D) = sgn(D)*(k1*d_b + k2*(|D|-d_b)) beyond,
      T = K(Delta_e)*(1 + eps(q)) + c_t*Delta' + k_h*x
  k1 = 7.0e6 N m/rad (+-3 %), k2 = 1.45e7 N m/rad (+-3 %), d_b = 1.5e-3 rad, c_t = 2.6e4 N m s/rad
  (0.52 deg of twist at 120 kN m). Delta_e = Delta nominally (backlash, transmission error
  change it), eps = 0 nominally (position_stiffness), k_h*x = 0 nominally (hysteresis).
  The true twist of the truth table is twist = mean_k(theta_k)/N - q (mesh deflections are
  ~1e-8 rad referred to the output, so twist ~= Delta).
Drives (S120-like): one speed PI on the mean motor speed, Kp = 2.4 N m s/rad, Ki = 24 N m/rad,
  torque demand split by campaign load shares s_k (1/3 +- 3 %, sum 1) plus an anti-backlash
  torque bias b = (+0.3, -0.15, -0.15) N m (sum 0). Scheme 3 adds an outer position loop on the
  referred motor angle u: omega_ref = N*(qd_d + 2.0*(q_d - u)).

Loading device: a magnetic-powder brake behind a step-up gear on a compliant loading shaft
  (stiffness k_s = 2e7 N m/rad, damping c_s = 2e4 N m s/rad; the load cell measures the shaft
  torque tau_L = k_s*(q - q_b) + c_s*(q' - q_b')). Brake side (inertia J_b = 720 kg m^2 referred
  to the output): J_b*q_b'' = tau_L - T_B(i_e)*tanh(q_b'/2e-4) - c_d*q_b', c_d = 1000 N m s/rad
  (residual powder drag), T_B(i) = T_sat*tanh(i/i_s) (saturating, T_sat = 160 kN m +-3 %,
  i_s = 1 A), excitation current first order i_e' = (i_cmd - i_e)/0.15 s. The controller's
  i_cmd = i_s*atanh(min(|tau_cmd| + 0.15 s*d|tau_cmd|/dt + trim, 0.97*T_sat_nominal)/T_sat_nominal)
  (lead for the excitation lag) with an integral trim trim' = 0.7/s*(|tau_cmd| - dir*tau_L)
  (decaying to 0 while no load is asked). The brake
  always opposes motion: the paper's positive loading for direction +1, negative for -1.
  Hydraulic bending moment 80 kN m and shear 90 kN (first order, 0.8 s) during schemes 1 and 2
  (p_hyd = m_bend/(0.01 m^2 * 0.5 m) + 0.3 MPa); they do not act on the joint's torque balance.

Thermal (two nodes): gearbox oil/gear node T_g (C_g = 1.2e4 J/K) and housing T_h (C_h = 2e5 J/K):
  C_g*T_g' = |F_gms*q'| + 3*b_m*omega^2 - 40*(T_g - T_h);  C_h*T_h' = 40*(T_g - T_h) - 25*(T_h - T_amb)
  with T_g(0) = T_h(0) = temp_joint_c and T_amb = 22 C +- 1 C (campaign). Motor windings:
  C_w*T_w' = R*(1 + 0.0039*(T_w - 20))*i^2 - (T_w - T_amb)/R_th, R = 0.8 ohm, C_w = 1500 J/K,
  R_th = 0.5 K/W, starting at temp_joint_c.

Integrator: Dormand-Prince 5(4) with error control (RMS norm, per-state absolute tolerances,
  angles with absolute tolerance only, PI step-size controller), FSAL, the 4th-order continuous extension (dense output) at a record
  grid of ~1 kHz, step floor 2e-6 s (a step at the floor is accepted so stick-slip cannot stall
  it), step ceiling 5 ms; written in numba.

Schemes (paper section II-B)
----------------------------
1: idle at rest 0-1 s, motor speed ramp 1-2 s to direction*motor_speed_rpm, brake load ramp
   0 -> 120 kN m over 3-35 s ("load"), 120 kN m -> 0 over 35-67 s ("unload"), idle, speed ramp
   down 68-69.5 s; 70 s.
2: as 1 but loading in 10 kN m steps (1 s ramp "load", 2 s pause "hold") up to 120 kN m from
   3 s, unload 39-47 s, ramp down 47.5-48.5 s; 49 s.
3: paper Eq. 12, a fifth-order Fourier trajectory (base period 20 s) starting at rest at q = 0,
   peak output speed 0.024 rad/s (motor < 3000 r/min), +-~5 deg, times `direction`, `periods`
   periods; no load ("excite").

Sensors (stated in meta["sensors"], SensorSpec)
-----------------------------------------------
q: output encoder, rounded to encoder_res_deg (default 0.01 deg); u: mean of the three motor
encoders (motor_counts_per_rev counts, default 16384) / N; torque: transducer, noise_sd
torque_noise (150 N m), ADC step torque_adc_step (10 N m), stated pure lag torque_lag_s;
torque_load: load cell, load_noise (80 N m), load_adc_step (10 N m), load_lag_s; currents:
current_noise (0.02 A) and current_res (0.001 A); speeds: speed_noise (0.05 rad/s) at 1e-3 rad/s;
temperatures: temp_noise (0.05 C) at temp_res (0.1 C), temp_joint reads the gearbox node T_g,
temp_m1..3 the windings; qd: offline central difference of the
quantised q over +-25 ms; ud: mean measured motor speed / N; torsion = q - u (measured).
m_bend (noise 200 N m), f_shear (noise 200 N), p_hyd (noise 2e4 Pa).

Unstated imperfections (params["unstated"], per campaign)
---------------------------------------------------------
- torque transducer zero offset, uniform +-40 N m, plus bending-moment crosstalk into the torque
  gauge, 0.05-0.10 % of m_bend (40-80 N m at 80 kN m)           [vocabulary: torque_offset]
- torque reading's fieldbus latency, 2-4 ms, beyond the stated lag [vocabulary: time_delay]
- output encoder interpolation error: 0.15*resolution amplitude, period 8*resolution
- load cell gain error, +-0.1 %
- ambient temperature 22 +- 1 C (drives the thermal model)

Effects (effects={name: {"form": f, "scale": s}}, 0 <= s <= SCALE_MAX = 10); sizes at scale 1
-----------------------------------------------------------------------------------------------
stribeck: s(v) = f_c + 400*s*shape(|v|/vs), vs = 2.5e-3 rad/s; shapes
  exponential exp(-x), gaussian exp(-x^2), lorentzian 1/(1+x^2), root exp(-sqrt x),
  rational 1/(1+x)^2 (~130-175 N m at 300 r/min, nil at 3000 r/min).
load_dependent_friction (|T| the transmitted torque):
  coulomb: s += 0.003*s*|T| (360 N m at 120 kN m);
  coulomb_viscous: s and f_v multiplied by 1 + 0.12*s*|T|/1.2e5;
  power_flow: s += (0.004 if T*v > 0 [driving] else 0.0015)*s*|T| (smooth switch, 5 W).
temperature_friction (T_g the gearbox node, T_ref = 35 C):
  viscous_exp: f_v*(1 + s*(exp(-0.02*(T_g-T_ref)) - 1)) (multiplicative);
  coulomb_linear: f_c + 12*s*(T_ref - T_g) N m (additive, 240 N m at 15 C);
  both_poly: f_c and f_v times 1 + s*(0.08*d + 0.04*d^2), d = (T_ref - T_g)/20 K.
  (factors clamped >= 0.1)
gear_ripple: output_harmonics: torque on the output 250*s*(sin(48q+p1) + 0.5 sin(96q+p2)) N m;
  motor_angle: transmission error on the motor shaft angle psi = n1*phi,
  Delta_e -= (250*s/1.2e7)*(sin(2psi+p1) + 0.4 sin(4psi+p2)) rad;
  load_modulated: torque on the output 250*s*(0.3 + |T|/1.2e5)*sin(48q+p1) N m.
torque_offset (torque reading only): constant 250*s N m; linear_drift 250*s*t/60 N m;
  exp_settle 300*s*(1-exp(-t/20 s)) N m; bending_crosstalk 0.003*s*m_bend.
time_delay (a reading only): torque 25*s ms; q 1.0*s ms; load (torque_load) 25*s ms.
hysteresis (in the transmission, T += k_h*x):
  bouc_wen_n1: x' = D' - 1400|D'|x - 600 D'|x|, x_max = 5e-4 rad, k_h = 6e5*s (300 N m);
  bouc_wen_n2: x' = D' - 2.8e6|D'||x|x - 1.2e6 D' x^2, x_max = 5e-4 rad, k_h = 6e5*s;
  dahl: x' = (D' - |D'|x)/3e-4 rad, torque 300*s*x N m.
backlash (dead zone of half width b = 3e-5*s rad on Delta): sharp; tanh (D - b*tanh(D/b));
  quadratic (D^2/(4b) sgn D inside |D| < 2b).
asymmetric_friction: coulomb: s = f_c +- 125*s (v > 0 / v < 0); viscous: f_v*(1 +- 0.5*s);
  both: the two together (smooth in v over 1e-4 rad/s; clamped >= 0.2 f_c, >= 0.1 f_v).
periodic_disturbance (out of vocabulary, torque on the output): sine 300*s*sin(2 pi 0.73 t);
  pump_pulses 300*s*(2|sin(pi 2.5 t)| - 4/pi)*1.5; two_tone 300*s*(0.6 sin(2 pi 0.5 t) +
  0.6 sin(2 pi 1.7 t + 1)).
position_stiffness (out of vocabulary): eps(q) = 0.004*s*cos(q) (once_per_rev),
  0.004*s*cos(3q) (three_lobe), 0.004*s*q/(0.5 rad) (linear).
sensor_drift (out of vocabulary, readings only): q_linear q += 3e-5*s*t/60 rad; load_linear
  torque_load += 250*s*t/60 N m; u_wander u += 3e-5*s*(sin(2 pi t/47 s + p) - sin p) rad.
second_resonance (out of vocabulary): a secondary inertia rho*I, rho = 0.1*s (0.25*s for
  output_hub_high; <= 0.8), on a
  spring-damper (zeta 0.015): output_hub (7 Hz, taken out of the output body: total inertia
  unchanged), output_hub_high (14 Hz, likewise), loading_shaft (9 Hz, attached to the brake
  side, added there); it rings after load changes, reversals and starts.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pandas as pd
from numba import njit

RIG_NAME = "rig_u"
REDUCTION = 11000.0
SEED_IS_CAMPAIGN = True
SCALE_MAX = 10.0

EFFECT_FORMS: dict[str, tuple[str, ...]] = {
    "stribeck": ("exponential", "gaussian", "lorentzian", "root", "rational"),
    "load_dependent_friction": ("coulomb", "coulomb_viscous", "power_flow"),
    "temperature_friction": ("viscous_exp", "coulomb_linear", "both_poly"),
    "gear_ripple": ("output_harmonics", "motor_angle", "load_modulated"),
    "torque_offset": ("constant", "linear_drift", "exp_settle", "bending_crosstalk"),
    "time_delay": ("torque", "q", "load"),
    "hysteresis": ("bouc_wen_n1", "bouc_wen_n2", "dahl"),
    "backlash": ("sharp", "tanh", "quadratic"),
    "asymmetric_friction": ("coulomb", "viscous", "both"),
    "periodic_disturbance": ("sine", "pump_pulses", "two_tone"),
    "position_stiffness": ("once_per_rev", "three_lobe", "linear"),
    "sensor_drift": ("q_linear", "load_linear", "u_wander"),
    "second_resonance": ("output_hub", "output_hub_high", "loading_shaft"),
}
OUT_OF_VOCABULARY = ("periodic_disturbance", "position_stiffness", "sensor_drift",
                     "second_resonance")
SENSOR_EFFECTS = ("torque_offset", "time_delay", "sensor_drift")
"""Effects that act on readings only (the true states are those of the nominal run)."""

UNSTATED_VOCABULARY: dict[str, str] = {
    "torque_offset": "torque transducer zero offset (+-40 N m) plus bending-moment crosstalk "
                     "(0.05-0.10 % of m_bend) on the torque reading",
    "time_delay": "2-4 ms fieldbus latency of the torque reading beyond its stated lag",
}

TABLE3 = {"I": 6685.166, "mr_x": 20.779, "mr_y": -34.543, "f_v": 8683.272, "f_c": 2352.66}
"""Paper Table 3 (least squares) values of Eq. 4."""
G = 9.81
N1 = 10.0
N2 = REDUCTION / N1
RATED_TORQUE = 120e3
SCHEME3_PERIOD = 20.0

# --- parameter vector layout (numba reads these module constants at compile time) -----------
P_I, P_MRX, P_MRY, P_FV, P_FC = 0, 1, 2, 3, 4
P_JM = 5          # 5, 6, 7
P_KT = 8
P_IMAX = 9        # 9, 10, 11
P_KM, P_CM, P_BM, P_TAUC = 12, 13, 14, 15
P_SHARE = 16      # 16, 17, 18
P_BIAS = 19       # 19, 20, 21
P_KP, P_KI, P_KPOS, P_J1 = 22, 23, 24, 25
P_K1, P_K2, P_DB, P_CT = 26, 27, 28, 29
P_KS, P_CS, P_JB, P_CD, P_TSAT, P_IS, P_TAUE, P_VE, P_KTRIM, P_TSATN = 30, 31, 32, 33, 34, 35, 36, 37, 38, 39
P_GA = 40         # 40..43
P_GZ = 44         # 44..47
P_GC, P_GD = 48, 49
P_CG, P_CH, P_GGH, P_GHA, P_TAMB = 50, 51, 52, 53, 54
P_RW, P_CW, P_RTH = 55, 56, 57
P_SCHEME, P_DIR, P_WF, P_Q0 = 58, 59, 60, 61
P_FA = 62         # 62..66
P_FB = 67         # 67..71
NP = 72

# effect slots (the sensor-only effects are applied outside the kernel)
E_ST_F, E_ST_DS, E_ST_VS = 0, 1, 2
E_LD_F, E_LD_A, E_LD_B = 3, 4, 5
E_TF_F, E_TF_A, E_TF_TREF = 6, 7, 8
E_GR_F, E_GR_A, E_GR_P1, E_GR_P2 = 9, 10, 11, 12
E_HY_F, E_HY_K = 13, 14
E_BL_F, E_BL_B = 15, 16
E_AS_F, E_AS_A = 17, 18
E_PD_F, E_PD_A = 19, 20
E_PS_F, E_PS_E = 21, 22
E_SR_F, E_SR_RHO, E_SR_W, E_SR_Z = 23, 24, 25, 26
NE = 27

# state layout
S_Q, S_QD, S_DEL, S_PHID = 0, 1, 2, 3
S_D = 4           # 4..6 mesh deflections theta_k - n1*phi [motor rad]
S_W = 7           # 7..9 motor speeds [rad/s]
S_I = 10          # 10..12 motor currents [A]
S_PI = 13         # speed PI integral [rad]
S_SFT, S_QBD = 14, 15   # loading shaft twist q - q_b, brake side speed
S_IE, S_TRIM = 16, 17
S_Z = 18          # 18..21 GMS elements
S_TG, S_TH = 22, 23
S_TW = 24         # 24..26
S_HX = 27
S_R2, S_R2D = 28, 29
NS = 30

# aux outputs
A_T, A_TL, A_F, A_TCMD, A_WREF, A_GRAV, A_TX, A_S, A_ICMD, A_FV, A_TR2 = range(11)
NA = 11


# ============================================================================================
# numba kernel
# ============================================================================================

@njit(cache=True)
def _pwl(t, tb, vb):
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
    w = (t - tb[lo]) / (tb[hi] - tb[lo])
    return vb[lo] + w * (vb[hi] - vb[lo])


@njit(cache=True)
def _pwl_slope(t, tb, vb):
    n = tb.shape[0]
    if t < tb[0] or t >= tb[n - 1]:
        return 0.0
    for j in range(n - 1):
        if tb[j] <= t < tb[j + 1]:
            return (vb[j + 1] - vb[j]) / (tb[j + 1] - tb[j])
    return 0.0


@njit(cache=True)
def _k2slope(d, k1, k2, db):
    ad = abs(d)
    if ad <= db:
        return k1 * d
    f = k1 * db + k2 * (ad - db)
    return f if d > 0 else -f


@njit(cache=True)
def _rhs(t, y, p, e, tb, vb, ts, vs, dy, aux):
    N = N1 * N2
    q = y[S_Q]
    qd = y[S_QD]
    dirn = p[P_DIR]
    # ---- references -----------------------------------------------------------------------
    th_mean = 0.0
    for k in range(3):
        th_mean += y[S_D + k]
    th_mean /= 3.0
    phi = N2 * (y[S_DEL] + q)
    u = (N1 * phi + th_mean) / N
    if p[P_SCHEME] == 3.0:
        wf = p[P_WF]
        qdes = p[P_Q0]
        qdd = 0.0
        for l in range(1, 6):
            a = p[P_FA + l - 1]
            b = p[P_FB + l - 1]
            qdes += a / (wf * l) * math.sin(wf * l * t) - b / (wf * l) * math.cos(wf * l * t)
            qdd += a * math.cos(wf * l * t) + b * math.sin(wf * l * t)
        qdes *= dirn
        qdd *= dirn
        wref = N * (qdd + p[P_KPOS] * (qdes - u))
        tcmd = 0.0
        tcmd_rate = 0.0
    else:
        wref = _pwl(t, ts, vs)
        tcmd = _pwl(t, tb, vb)
        tcmd_rate = _pwl_slope(t, tb, vb)
    # ---- drives -----------------------------------------------------------------------------
    wmean = (y[S_W] + y[S_W + 1] + y[S_W + 2]) / 3.0
    err = wref - wmean
    taud = p[P_KP] * err + p[P_KI] * y[S_PI]
    sat = 0.0
    for k in range(3):
        lim = p[P_IMAX + k] * p[P_KT]
        if abs(p[P_SHARE + k] * taud) > lim:
            sat = 1.0
    dy[S_PI] = err if (sat == 0.0 or err * taud < 0.0) else 0.0
    phid = y[S_PHID]
    summ = 0.0
    for k in range(3):
        icmd = (p[P_SHARE + k] * taud + p[P_BIAS + k]) / p[P_KT]
        im = p[P_IMAX + k]
        if icmd > im:
            icmd = im
        elif icmd < -im:
            icmd = -im
        dy[S_I + k] = (icmd - y[S_I + k]) / p[P_TAUC]
        wk = y[S_W + k]
        mk = p[P_KM] * y[S_D + k] + p[P_CM] * (wk - N1 * phid)
        summ += mk
        dy[S_D + k] = wk - N1 * phid
        dy[S_W + k] = (p[P_KT] * y[S_I + k] - mk - p[P_BM] * wk) / p[P_JM + k]
    # ---- transmission -------------------------------------------------------------------------
    dl = y[S_DEL]
    dld = phid / N2 - qd
    de = dl
    gr_f = e[E_GR_F]
    if gr_f == 2.0:
        psi = N1 * phi
        de -= e[E_GR_A] / 1.2e7 * (math.sin(2.0 * psi + e[E_GR_P1])
                                   + 0.4 * math.sin(4.0 * psi + e[E_GR_P2]))
    blf = e[E_BL_F]
    if blf != 0.0:
        b = e[E_BL_B]
        if blf == 1.0:
            if de > b:
                de = de - b
            elif de < -b:
                de = de + b
            else:
                de = 0.0
        elif blf == 2.0:
            de = de - b * math.tanh(de / b)
        else:
            ad = abs(de)
            if ad < 2.0 * b:
                de = de * ad / (4.0 * b)
            else:
                de = de - b if de > 0 else de + b
    kfac = 1.0
    psf = e[E_PS_F]
    if psf == 1.0:
        kfac += e[E_PS_E] * math.cos(q)
    elif psf == 2.0:
        kfac += e[E_PS_E] * math.cos(3.0 * q)
    elif psf == 3.0:
        kfac += e[E_PS_E] * q / 0.5
    T = _k2slope(de, p[P_K1], p[P_K2], p[P_DB]) * kfac + p[P_CT] * dld
    hyf = e[E_HY_F]
    hx = y[S_HX]
    if hyf == 1.0:
        T += e[E_HY_K] * hx
        dy[S_HX] = dld - 1400.0 * abs(dld) * hx - 600.0 * dld * abs(hx)
    elif hyf == 2.0:
        T += e[E_HY_K] * hx
        dy[S_HX] = dld - 2.8e6 * abs(dld) * abs(hx) * hx - 1.2e6 * dld * hx * hx
    elif hyf == 3.0:
        T += e[E_HY_K] * hx
        dy[S_HX] = (dld - abs(dld) * hx) / 3e-4
    else:
        dy[S_HX] = 0.0
    dy[S_DEL] = dld
    # ---- friction sliding level and viscous slope ---------------------------------------------
    fc = p[P_FC]
    fv = p[P_FV]
    s = fc
    fvv = fv
    Tg = y[S_TG]
    tff = e[E_TF_F]
    if tff != 0.0:
        dT = Tg - e[E_TF_TREF]
        if tff == 1.0:
            fac = 1.0 + e[E_TF_A] * (math.exp(-0.02 * dT) - 1.0)
            fvv = fvv * max(fac, 0.1)
        elif tff == 2.0:
            s = max(s + 12.0 * e[E_TF_A] * (-dT), 0.1 * fc)
        else:
            dd = -dT / 20.0
            fac = max(1.0 + e[E_TF_A] * (0.08 * dd + 0.04 * dd * dd), 0.1)
            s *= fac
            fvv *= fac
    ldf = e[E_LD_F]
    if ldf == 1.0:
        s += e[E_LD_A] * abs(T)
    elif ldf == 2.0:
        fac = 1.0 + e[E_LD_A] * abs(T) / 1.2e5
        s *= fac
        fvv *= fac
    elif ldf == 3.0:
        w = 0.5 * (1.0 + math.tanh(T * qd / 5.0))
        s += (w * e[E_LD_A] + (1.0 - w) * e[E_LD_B]) * abs(T)
    asf = e[E_AS_F]
    if asf != 0.0:
        sg = math.tanh(qd / 1e-4)
        if asf == 1.0 or asf == 3.0:
            s = max(s + 125.0 * e[E_AS_A] * sg, 0.2 * fc)
        if asf == 2.0 or asf == 3.0:
            fvv = fvv * max(1.0 + 0.5 * e[E_AS_A] * sg, 0.1)
    stf = e[E_ST_F]
    if stf != 0.0:
        x = abs(qd) / e[E_ST_VS]
        if stf == 1.0:
            sh = math.exp(-x)
        elif stf == 2.0:
            sh = math.exp(-x * x)
        elif stf == 3.0:
            sh = 1.0 / (1.0 + x * x)
        elif stf == 4.0:
            sh = math.exp(-math.sqrt(x))
        else:
            sh = 1.0 / ((1.0 + x) * (1.0 + x))
        s += e[E_ST_DS] * sh
    if s < 1.0:
        s = 1.0
    # ---- GMS --------------------------------------------------------------------------------
    Fel = 0.0
    gd = p[P_GD]
    for i in range(4):
        al = p[P_GA + i]
        kap = al * fc / p[P_GZ + i]
        z = y[S_Z + i]
        Fi = kap * z
        Fel += Fi
        ar = abs(Fi / (al * s))
        if qd * z > 0.0:
            if ar < 1.0 - gd:
                dz = qd
            elif ar <= 1.0:
                dz = qd * (1.0 - ar) / gd
            else:
                dz = (1.0 if z > 0 else -1.0) * p[P_GC] * (1.0 - ar)
        else:
            dz = qd
        dy[S_Z + i] = dz
    F = Fel + fvv * qd
    # ---- output-side extra torques ----------------------------------------------------------
    tx = 0.0
    if gr_f == 1.0:
        tx += e[E_GR_A] * (math.sin(48.0 * q + e[E_GR_P1]) + 0.5 * math.sin(96.0 * q + e[E_GR_P2]))
    elif gr_f == 3.0:
        tx += e[E_GR_A] * (0.3 + abs(T) / 1.2e5) * math.sin(48.0 * q + e[E_GR_P1])
    pdf = e[E_PD_F]
    if pdf == 1.0:
        tx += e[E_PD_A] * math.sin(2.0 * math.pi * 0.73 * t)
    elif pdf == 2.0:
        tx += e[E_PD_A] * 1.5 * (2.0 * abs(math.sin(math.pi * 2.5 * t)) - 4.0 / math.pi)
    elif pdf == 3.0:
        tx += e[E_PD_A] * (0.6 * math.sin(2.0 * math.pi * 0.5 * t)
                           + 0.6 * math.sin(2.0 * math.pi * 1.7 * t + 1.0))
    # ---- loading shaft and brake ------------------------------------------------------------
    qbd = y[S_QBD]
    tL = p[P_KS] * y[S_SFT] + p[P_CS] * (qd - qbd)
    dy[S_SFT] = qd - qbd
    tsn = p[P_TSATN]
    if tcmd > 0.0:
        dem = tcmd + p[P_TAUE] * tcmd_rate + y[S_TRIM]
        if dem < 0.0:
            dem = 0.0
        if dem > 0.97 * tsn:
            dem = 0.97 * tsn
        icmd_b = p[P_IS] * math.atanh(dem / tsn)
        dy[S_TRIM] = p[P_KTRIM] * (tcmd - dirn * tL)
    else:
        icmd_b = 0.0
        dy[S_TRIM] = -y[S_TRIM] / 0.5
    dy[S_IE] = (icmd_b - y[S_IE]) / p[P_TAUE]
    tB = p[P_TSAT] * math.tanh(y[S_IE] / p[P_IS]) * math.tanh(qbd / p[P_VE])
    # ---- second resonance -------------------------------------------------------------------
    srf = e[E_SR_F]
    ihub = p[P_I]
    tr2 = 0.0
    jb_extra = 0.0
    if srf != 0.0:
        rho = e[E_SR_RHO]
        w2 = e[E_SR_W]
        if srf == 3.0:
            j2 = rho * p[P_I]
            base = y[S_QBD]
            basep = -(y[S_SFT]) + q   # q_b = q - sft
        else:
            j2 = rho * p[P_I]
            ihub = p[P_I] - j2
            base = qd
            basep = q
        k2 = j2 * w2 * w2
        c2 = 2.0 * e[E_SR_Z] * j2 * w2
        tr2 = k2 * (y[S_R2] - basep) + c2 * (y[S_R2D] - base)
        dy[S_R2] = y[S_R2D]
        dy[S_R2D] = -tr2 / j2
        if srf == 3.0:
            jb_extra = tr2
            tr2 = 0.0
    else:
        dy[S_R2] = 0.0
        dy[S_R2D] = 0.0
    grav = G * (p[P_MRX] * math.sin(q) + p[P_MRY] * math.cos(q))
    dy[S_Q] = qd
    dy[S_QD] = (T - tL - grav - F + tx + tr2) / ihub
    dy[S_QBD] = (tL - tB - p[P_CD] * qbd + jb_extra) / p[P_JB]
    dy[S_PHID] = (N1 * summ - T / N2) / p[P_J1]
    # ---- thermal ----------------------------------------------------------------------------
    wsq = y[S_W] ** 2 + y[S_W + 1] ** 2 + y[S_W + 2] ** 2
    pl = abs(F * qd) + p[P_BM] * wsq
    Th = y[S_TH]
    dy[S_TG] = (pl - p[P_GGH] * (Tg - Th)) / p[P_CG]
    dy[S_TH] = (p[P_GGH] * (Tg - Th) - p[P_GHA] * (Th - p[P_TAMB])) / p[P_CH]
    for k in range(3):
        tw = y[S_TW + k]
        ik = y[S_I + k]
        dy[S_TW + k] = (p[P_RW] * (1.0 + 0.0039 * (tw - 20.0)) * ik * ik
                        - (tw - p[P_TAMB]) / p[P_RTH]) / p[P_CW]
    aux[A_T] = T
    aux[A_TL] = tL
    aux[A_F] = F
    aux[A_TCMD] = dirn * tcmd
    aux[A_WREF] = wref
    aux[A_GRAV] = grav
    aux[A_TX] = tx
    aux[A_S] = s
    aux[A_ICMD] = icmd_b
    aux[A_FV] = fvv
    aux[A_TR2] = tr2


# Dormand-Prince 5(4) tableau and its continuous extension (Hairer, Norsett, Wanner).
_C2, _C3, _C4, _C5 = 1.0 / 5.0, 3.0 / 10.0, 4.0 / 5.0, 8.0 / 9.0
_A21 = 1.0 / 5.0
_A31, _A32 = 3.0 / 40.0, 9.0 / 40.0
_A41, _A42, _A43 = 44.0 / 45.0, -56.0 / 15.0, 32.0 / 9.0
_A51, _A52, _A53, _A54 = 19372.0 / 6561.0, -25360.0 / 2187.0, 64448.0 / 6561.0, -212.0 / 729.0
_A61, _A62, _A63, _A64, _A65 = (9017.0 / 3168.0, -355.0 / 33.0, 46732.0 / 5247.0, 49.0 / 176.0,
                                -5103.0 / 18656.0)
_A71, _A73, _A74, _A75, _A76 = (35.0 / 384.0, 500.0 / 1113.0, 125.0 / 192.0, -2187.0 / 6784.0,
                                11.0 / 84.0)
_E1, _E3, _E4, _E5, _E6, _E7 = (71.0 / 57600.0, -71.0 / 16695.0, 71.0 / 1920.0,
                                -17253.0 / 339200.0, 22.0 / 525.0, -1.0 / 40.0)
_D1, _D3, _D4, _D5, _D6, _D7 = (-12715105075.0 / 11282082432.0, 87487479700.0 / 32700410799.0,
                                -10690763975.0 / 1880347072.0, 701980252875.0 / 199316789632.0,
                                -1453857185.0 / 822651844.0, 69997945.0 / 29380423.0)


@njit(cache=True)
def _integrate(p, e, tb, vb, ts, vs, y0, dt_rec, n_rec, atol, rtol, h_min, h_max):
    """Dormand-Prince 5(4) with error control and dense output at t = i*dt_rec."""
    ns = y0.shape[0]
    Y = np.empty((n_rec, ns))
    A = np.empty((n_rec, NA))
    aux = np.empty(NA)
    k1 = np.empty(ns)
    k2 = np.empty(ns)
    k3 = np.empty(ns)
    k4 = np.empty(ns)
    k5 = np.empty(ns)
    k6 = np.empty(ns)
    k7 = np.empty(ns)
    yt = np.empty(ns)
    yn = np.empty(ns)
    yr = np.empty(ns)
    dtmp = np.empty(ns)
    y = y0.copy()
    t = 0.0
    t_end = (n_rec - 1) * dt_rec
    _rhs(t, y, p, e, tb, vb, ts, vs, k1, aux)
    for j in range(ns):
        Y[0, j] = y[j]
    for j in range(NA):
        A[0, j] = aux[j]
    nxt = 1
    h = 1e-4
    nacc = 0
    nrej = 0
    err_old = 1e-4
    while nxt < n_rec:
        if t + h > t_end:
            h = t_end - t
            if h <= 0.0:
                h = h_min
        for j in range(ns):
            yt[j] = y[j] + h * _A21 * k1[j]
        _rhs(t + _C2 * h, yt, p, e, tb, vb, ts, vs, k2, aux)
        for j in range(ns):
            yt[j] = y[j] + h * (_A31 * k1[j] + _A32 * k2[j])
        _rhs(t + _C3 * h, yt, p, e, tb, vb, ts, vs, k3, aux)
        for j in range(ns):
            yt[j] = y[j] + h * (_A41 * k1[j] + _A42 * k2[j] + _A43 * k3[j])
        _rhs(t + _C4 * h, yt, p, e, tb, vb, ts, vs, k4, aux)
        for j in range(ns):
            yt[j] = y[j] + h * (_A51 * k1[j] + _A52 * k2[j] + _A53 * k3[j] + _A54 * k4[j])
        _rhs(t + _C5 * h, yt, p, e, tb, vb, ts, vs, k5, aux)
        for j in range(ns):
            yt[j] = y[j] + h * (_A61 * k1[j] + _A62 * k2[j] + _A63 * k3[j] + _A64 * k4[j]
                                + _A65 * k5[j])
        _rhs(t + h, yt, p, e, tb, vb, ts, vs, k6, aux)
        for j in range(ns):
            yn[j] = y[j] + h * (_A71 * k1[j] + _A73 * k3[j] + _A74 * k4[j] + _A75 * k5[j]
                                + _A76 * k6[j])
        _rhs(t + h, yn, p, e, tb, vb, ts, vs, k7, aux)
        err = 0.0
        for j in range(ns):
            ej = h * (_E1 * k1[j] + _E3 * k3[j] + _E4 * k4[j] + _E5 * k5[j] + _E6 * k6[j]
                      + _E7 * k7[j])
            sc = atol[j] + rtol[j] * max(abs(y[j]), abs(yn[j]))
            r = ej / sc
            err += r * r
        err = math.sqrt(err / ns)
        if err <= 1.0 or h <= h_min * 1.0000001:
            nacc += 1
            tn = t + h
            # dense output for record instants in (t, tn]
            while nxt < n_rec and nxt * dt_rec <= tn + 1e-12:
                th = (nxt * dt_rec - t) / h
                if th > 1.0:
                    th = 1.0
                th1 = 1.0 - th
                for j in range(ns):
                    r1 = y[j]
                    r2 = yn[j] - y[j]
                    r3 = h * k1[j] - r2
                    r4 = r2 - h * k7[j] - r3
                    r5 = h * (_D1 * k1[j] + _D3 * k3[j] + _D4 * k4[j] + _D5 * k5[j]
                              + _D6 * k6[j] + _D7 * k7[j])
                    yr[j] = r1 + th * (r2 + th1 * (r3 + th * (r4 + th1 * r5)))
                _rhs(nxt * dt_rec, yr, p, e, tb, vb, ts, vs, dtmp, aux)
                for j in range(ns):
                    Y[nxt, j] = yr[j]
                for j in range(NA):
                    A[nxt, j] = aux[j]
                nxt += 1
            t = tn
            for j in range(ns):
                y[j] = yn[j]
                k1[j] = k7[j]
            # PI step-size control
            e_ = max(err, 1e-10)
            fac = 0.9 * e_ ** (-0.7 / 5.0) * err_old ** (0.4 / 5.0)
            fac = min(max(fac, 0.2), 5.0)
            err_old = max(err, 1e-4)
            h = h * fac
        else:
            nrej += 1
            h = h * max(0.2, 0.9 * err ** (-0.2))
        if h < h_min:
            h = h_min
        if h > h_max:
            h = h_max
    return Y, A, nacc, nrej


# ============================================================================================
# Python side: sensors, campaign, schedules
# ============================================================================================

def _check_number(name: str, v: Any, lo: float, hi: float) -> float:
    if isinstance(v, bool) or not isinstance(v, (int, float, np.integer, np.floating)):
        raise ValueError(f"{name} must be a number, got {v!r}")
    x = float(v)
    if not math.isfinite(x) or x < lo or x > hi:
        raise ValueError(f"{name} must be finite and in [{lo}, {hi}], got {v!r}")
    return x


@dataclass
class SensorSpec:
    """What the bench's sensors resolve (stated in the run's meta["sensors"]).

    All values SI (temperatures in C); every field is validated on construction."""

    sample_rate_hz: float = 100.0
    encoder_res_deg: float = 0.01
    torque_noise: float = 150.0
    torque_lag_s: float = 0.0
    torque_adc_step: float = 10.0
    load_noise: float = 80.0
    load_adc_step: float = 10.0
    load_lag_s: float = 0.0
    motor_counts_per_rev: int = 16384
    current_noise: float = 0.02
    current_res: float = 0.001
    speed_noise: float = 0.05
    temp_noise: float = 0.05
    temp_res: float = 0.1

    _RANGES = {
        "sample_rate_hz": (10.0, 1000.0), "encoder_res_deg": (1e-6, 1.0),
        "torque_noise": (0.0, 1e4), "torque_lag_s": (0.0, 1.0), "torque_adc_step": (0.0, 1e4),
        "load_noise": (0.0, 1e4), "load_adc_step": (0.0, 1e4), "load_lag_s": (0.0, 1.0),
        "motor_counts_per_rev": (16, 2 ** 28), "current_noise": (0.0, 10.0),
        "current_res": (0.0, 1.0), "speed_noise": (0.0, 100.0), "temp_noise": (0.0, 10.0),
        "temp_res": (0.0, 5.0),
    }

    def __post_init__(self) -> None:
        for name, (lo, hi) in self._RANGES.items():
            v = getattr(self, name)
            x = _check_number(name, v, lo, hi)
            if name == "motor_counts_per_rev":
                if not float(v).is_integer():
                    raise ValueError(f"motor_counts_per_rev must be a whole number, got {v!r}")
                object.__setattr__(self, name, int(x))
            else:
                object.__setattr__(self, name, x)

    @property
    def q_res_rad(self) -> float:
        return math.radians(self.encoder_res_deg)

    @property
    def u_res_rad(self) -> float:
        return 2.0 * math.pi / self.motor_counts_per_rev / REDUCTION


@dataclass
class RigRun:
    """One simulated run: `samples`/`meta` in the run format, `truth` (true states on the same
    sample times: twist [rad], torque [N m], ...), `params` (machine, unstated, effects)."""

    samples: pd.DataFrame
    meta: dict[str, Any]
    truth: pd.DataFrame
    params: dict[str, Any] = field(default_factory=dict)


def campaign_machine(seed: int) -> dict[str, Any]:
    """The campaign's machine and unstated imperfections, drawn from `seed` alone."""
    rng = np.random.default_rng(np.random.SeedSequence([int(seed), 0x52494755]))

    def nrm(mean: float, rel: float) -> float:
        return float(mean * (1.0 + rel * np.clip(rng.standard_normal(), -2.0, 2.0)))

    m: dict[str, Any] = {
        "I": nrm(TABLE3["I"], 0.004), "mr_x": nrm(TABLE3["mr_x"], 0.02),
        "mr_y": nrm(TABLE3["mr_y"], 0.02), "f_v": nrm(TABLE3["f_v"], 0.0015),
        "f_c": nrm(TABLE3["f_c"], 0.003),
        "J_m": [nrm(0.020, 0.03) for _ in range(3)], "k_t": 1.30,
        "i_max": [float(15.0 * (1.0 + 0.05 * rng.uniform(-1, 1))) for _ in range(3)],
        "k_mesh": 5000.0, "c_mesh": 2.0, "b_m": 2e-4, "tau_c": 2e-3,
        "Kp": 2.4, "Ki": 24.0, "Kpos": 2.0, "J_1": 2.0,
        "k1": nrm(7.0e6, 0.03), "k2": nrm(1.45e7, 0.03), "d_b": 1.5e-3, "c_t": 2.6e4,
        "k_s": 2e7, "c_s": 2e4, "J_b": 720.0, "c_d": 1000.0,
        "T_sat": float(160e3 * (1.0 + 0.03 * rng.uniform(-1, 1))), "i_s": 1.0,
        "tau_e": 0.15, "v_e": 2e-4, "k_trim": 0.7, "T_sat_nominal": 160e3,
        "gms_alpha": [0.40, 0.30, 0.20, 0.10], "gms_zeta": [4e-5, 8e-5, 1.5e-4, 3e-4],
        "gms_C": 0.02, "gms_delta": 0.2,
        "C_g": 1.2e4, "C_h": 2e5, "G_gh": 40.0, "G_ha": 25.0,
        "T_amb": float(22.0 + rng.uniform(-1, 1)),
        "R_w": 0.8, "C_w": 1500.0, "R_th": 0.5,
        "N": REDUCTION, "n1": N1, "n2": N2,
    }
    sh = np.array([1.0 + 0.03 * rng.uniform(-1, 1) for _ in range(3)])
    m["share"] = [float(x) for x in sh / sh.sum()]
    m["bias"] = [0.3, -0.15, -0.15]
    unstated = {
        "torque_zero_offset_nm": float(rng.uniform(-40.0, 40.0)),
        "torque_bending_crosstalk": float(rng.uniform(5e-4, 1e-3)),
        "torque_extra_lag_s": float(rng.uniform(2e-3, 4e-3)),
        "encoder_interp_amp_res": 0.15,
        "encoder_interp_period_res": 8.0,
        "encoder_interp_phase": float(rng.uniform(0, 2 * math.pi)),
        "load_cell_gain_error": float(rng.uniform(-1e-3, 1e-3)),
        "ambient_c": m["T_amb"],
    }
    phases = rng.uniform(0, 2 * math.pi, size=4)
    m["ripple_phases"] = [float(x) for x in phases[:2]]
    m["wander_phase"] = float(phases[2])
    return {"machine": m, "unstated": unstated}


def stiffness_law(twist: np.ndarray | float, machine: dict[str, Any]) -> np.ndarray:
    """Nominal static transmitted torque [N m] for a twist [rad] (the two-slope law)."""
    d = np.asarray(twist, dtype=float)
    k1, k2, db = machine["k1"], machine["k2"], machine["d_b"]
    ad = np.abs(d)
    return np.where(ad <= db, k1 * d, np.sign(d) * (k1 * db + k2 * (ad - db)))


def _pvec(m: dict[str, Any], scheme: int, direction: int) -> np.ndarray:
    p = np.zeros(NP)
    p[P_I], p[P_MRX], p[P_MRY], p[P_FV], p[P_FC] = m["I"], m["mr_x"], m["mr_y"], m["f_v"], m["f_c"]
    p[P_JM:P_JM + 3] = m["J_m"]
    p[P_KT] = m["k_t"]
    p[P_IMAX:P_IMAX + 3] = m["i_max"]
    p[P_KM], p[P_CM], p[P_BM], p[P_TAUC] = m["k_mesh"], m["c_mesh"], m["b_m"], m["tau_c"]
    p[P_SHARE:P_SHARE + 3] = m["share"]
    p[P_BIAS:P_BIAS + 3] = m["bias"]
    p[P_KP], p[P_KI], p[P_KPOS], p[P_J1] = m["Kp"], m["Ki"], m["Kpos"], m["J_1"]
    p[P_K1], p[P_K2], p[P_DB], p[P_CT] = m["k1"], m["k2"], m["d_b"], m["c_t"]
    p[P_KS], p[P_CS], p[P_JB], p[P_CD] = m["k_s"], m["c_s"], m["J_b"], m["c_d"]
    p[P_TSAT], p[P_IS], p[P_TAUE], p[P_VE] = m["T_sat"], m["i_s"], m["tau_e"], m["v_e"]
    p[P_KTRIM], p[P_TSATN] = m["k_trim"], m["T_sat_nominal"]
    p[P_GA:P_GA + 4] = m["gms_alpha"]
    p[P_GZ:P_GZ + 4] = m["gms_zeta"]
    p[P_GC], p[P_GD] = m["gms_C"], m["gms_delta"]
    p[P_CG], p[P_CH], p[P_GGH], p[P_GHA], p[P_TAMB] = m["C_g"], m["C_h"], m["G_gh"], m["G_ha"], m["T_amb"]
    p[P_RW], p[P_CW], p[P_RTH] = m["R_w"], m["C_w"], m["R_th"]
    p[P_SCHEME] = float(scheme)
    p[P_DIR] = float(direction)
    a, b, q0, wf = _fourier()
    p[P_WF] = wf
    p[P_Q0] = q0
    p[P_FA:P_FA + 5] = a
    p[P_FB:P_FB + 5] = b
    return p


def _fourier() -> tuple[np.ndarray, np.ndarray, float, float]:
    """Eq. 12 coefficients: sum a_l = 0 and sum l*b_l = 0 (rest at t = 0), q(0) = 0, peak
    output speed 0.024 rad/s."""
    wf = 2.0 * math.pi / SCHEME3_PERIOD
    a = np.array([0.010, -0.004, 0.006, -0.008, -0.004])
    b = np.array([0.008, 0.006, -0.004, 0.002, -0.0032])
    tt = np.linspace(0.0, SCHEME3_PERIOD, 4001)
    ll = np.arange(1, 6)[:, None]
    v = (a[:, None] * np.cos(wf * ll * tt) + b[:, None] * np.sin(wf * ll * tt)).sum(0)
    k = 0.024 / np.abs(v).max()
    a, b = a * k, b * k
    q0 = float(np.sum(b / (wf * np.arange(1, 6))))
    return a, b, q0, wf


def _schedule(scheme: int, rpm: float | None, direction: int, periods: int):
    """Piecewise-linear brake torque magnitude (tb, vb), motor speed reference (ts, vs),
    duration and phase segments [(t_start, phase)]."""
    if scheme == 3:
        dur = periods * SCHEME3_PERIOD
        z = np.array([0.0, dur])
        return z, np.zeros(2), z, np.zeros(2), dur, [(0.0, "excite")]
    w = direction * float(rpm) * 2.0 * math.pi / 60.0
    if scheme == 1:
        tb = np.array([0.0, 3.0, 35.0, 67.0, 70.0])
        vb = np.array([0.0, 0.0, RATED_TORQUE, 0.0, 0.0])
        ts = np.array([0.0, 1.0, 2.0, 68.0, 69.5, 70.0])
        vs = np.array([0.0, 0.0, w, w, 0.0, 0.0])
        phases = [(0.0, "idle"), (3.0, "load"), (35.0, "unload"), (67.0, "idle")]
        return tb, vb, ts, vs, 70.0, phases
    tbl = [0.0, 3.0]
    vbl = [0.0, 0.0]
    phases = [(0.0, "idle")]
    t = 3.0
    for k in range(1, 13):
        phases.append((t, "load"))
        tbl += [t + 1.0, t + 3.0]
        vbl += [k * 10e3, k * 10e3]
        phases.append((t + 1.0, "hold"))
        t += 3.0
    tbl += [47.0, 49.0]
    vbl += [0.0, 0.0]
    phases += [(39.0, "unload"), (47.0, "idle")]
    ts = np.array([0.0, 1.0, 2.0, 47.5, 48.5, 49.0])
    vs = np.array([0.0, 0.0, w, w, 0.0, 0.0])
    return np.array(tbl), np.array(vbl), ts, vs, 49.0, phases


def _effect_vector(effects: dict[str, dict], machine: dict[str, Any]) -> tuple[np.ndarray, dict]:
    e = np.zeros(NE)
    e[E_ST_VS] = 2.5e-3
    e[E_TF_TREF] = 35.0
    e[E_SR_Z] = 0.015
    applied: dict[str, dict] = {}
    ph = machine["ripple_phases"]
    for name, spec in effects.items():
        form, s = spec["form"], spec["scale"]
        fi = float(EFFECT_FORMS[name].index(form) + 1)
        rec: dict[str, Any] = {"form": form, "scale": s}
        if name == "stribeck":
            e[E_ST_F], e[E_ST_DS] = fi, 400.0 * s
            rec.update(delta_s_nm=400.0 * s, v_s=2.5e-3)
        elif name == "load_dependent_friction":
            e[E_LD_F] = fi
            e[E_LD_A] = {1.0: 0.003, 2.0: 0.12, 3.0: 0.004}[fi] * s
            e[E_LD_B] = 0.0015 * s
            rec.update(a=e[E_LD_A], b=e[E_LD_B])
        elif name == "temperature_friction":
            e[E_TF_F], e[E_TF_A] = fi, s
            rec.update(t_ref_c=35.0)
        elif name == "gear_ripple":
            e[E_GR_F], e[E_GR_A] = fi, 250.0 * s
            e[E_GR_P1], e[E_GR_P2] = ph
            rec.update(amplitude_nm=250.0 * s, phases=list(ph))
        elif name == "hysteresis":
            e[E_HY_F] = fi
            e[E_HY_K] = 6e5 * s if fi in (1.0, 2.0) else 300.0 * s
            rec.update(k_h=e[E_HY_K])
        elif name == "backlash":
            e[E_BL_F], e[E_BL_B] = fi, 3e-5 * s
            rec.update(half_width_rad=3e-5 * s)
        elif name == "asymmetric_friction":
            e[E_AS_F], e[E_AS_A] = fi, s
        elif name == "periodic_disturbance":
            e[E_PD_F], e[E_PD_A] = fi, 300.0 * s
        elif name == "position_stiffness":
            e[E_PS_F], e[E_PS_E] = fi, 0.004 * s
        elif name == "second_resonance":
            e[E_SR_F] = fi
            e[E_SR_RHO] = min((0.25 if fi == 2.0 else 0.1) * s, 0.8)
            e[E_SR_W] = 2.0 * math.pi * {1.0: 7.0, 2.0: 14.0, 3.0: 9.0}[fi]
            rec.update(rho=e[E_SR_RHO], f_hz=e[E_SR_W] / 2.0 / math.pi)
        applied[name] = rec
    return e, applied


def _atol() -> tuple[np.ndarray, np.ndarray]:
    atol = np.full(NS, 1e-3)
    rtol = np.full(NS, 1e-4)
    atol[S_Q], atol[S_QD], atol[S_DEL], atol[S_PHID] = 1e-7, 1e-6, 2e-8, 1e-3
    atol[S_D:S_D + 3] = 2e-6
    atol[S_W:S_W + 3] = 5e-3
    atol[S_I:S_I + 3] = 2e-3
    atol[S_PI] = 1e-4
    atol[S_SFT], atol[S_QBD] = 2e-8, 1e-6
    atol[S_IE], atol[S_TRIM] = 1e-5, 1.0
    atol[S_Z:S_Z + 4] = 2e-8
    atol[S_TG], atol[S_TH] = 1e-3, 1e-3
    atol[S_TW:S_TW + 3] = 1e-3
    atol[S_HX], atol[S_R2], atol[S_R2D] = 2e-8, 1e-7, 1e-6
    for j in (S_Q, S_DEL, S_D, S_D + 1, S_D + 2, S_SFT, S_R2):
        rtol[j] = 0.0
    return atol, rtol


def _initial_state(m: dict[str, Any], temp: float) -> np.ndarray:
    """At rest at q = 0 with the transmission holding gravity."""
    y = np.zeros(NS)
    grav = G * m["mr_y"]                      # g*(mr_x sin 0 + mr_y cos 0)
    T0 = grav
    k1, db = m["k1"], m["d_b"]
    y[S_DEL] = T0 / k1 if abs(T0 / k1) <= db else math.copysign(db + (abs(T0) - k1 * db) / m["k2"], T0)
    taud = T0 / REDUCTION                       # motor-side total torque
    y[S_PI] = taud / m["Ki"]
    for k in range(3):
        tk = m["share"][k] * taud + m["bias"][k]
        y[S_I + k] = tk / m["k_t"]
        y[S_D + k] = tk / m["k_mesh"]
    y[S_TG] = y[S_TH] = temp
    y[S_TW:S_TW + 3] = temp
    return y


def _validate(scheme: Any, motor_speed_rpm: Any, direction: Any, temp_joint_c: Any,
              effects: Any, sensors: Any, periods: Any, seed: Any, run: Any) -> dict[str, dict]:
    if isinstance(scheme, bool) or scheme not in (1, 2, 3) or not isinstance(scheme, (int, np.integer)):
        raise ValueError(f"scheme must be 1, 2 or 3, got {scheme!r}")
    if scheme == 3:
        if motor_speed_rpm is not None:
            raise ValueError("motor_speed_rpm must be None for scheme 3 (a Fourier trajectory)")
    else:
        if motor_speed_rpm is None:
            raise ValueError("motor_speed_rpm is required for schemes 1 and 2")
        v = _check_number("motor_speed_rpm", motor_speed_rpm, 0.0, 3000.0)
        if v <= 0.0:
            raise ValueError(f"motor_speed_rpm must be in (0, 3000], got {motor_speed_rpm!r}")
    if isinstance(direction, bool) or not isinstance(direction, (int, np.integer)) \
            or direction not in (1, -1):
        raise ValueError(f"direction must be +1 or -1, got {direction!r}")
    _check_number("temp_joint_c", temp_joint_c, 15.0, 60.0)
    if isinstance(periods, bool) or not isinstance(periods, (int, np.integer)) or not 1 <= periods <= 20:
        raise ValueError(f"periods must be a whole number in [1, 20], got {periods!r}")
    for nm, v in (("seed", seed), ("run", run)):
        if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < 0:
            raise ValueError(f"{nm} must be a whole number >= 0, got {v!r}")
    if sensors is not None and not isinstance(sensors, SensorSpec):
        raise ValueError(f"sensors must be a SensorSpec or None, got {type(sensors).__name__}")
    if effects is None:
        return {}
    if not isinstance(effects, dict):
        raise ValueError(f"effects must be a dict name -> {{form, scale}}, got {type(effects).__name__}")
    out: dict[str, dict] = {}
    for name, spec in effects.items():
        if name not in EFFECT_FORMS:
            raise ValueError(f"effects: unknown effect {name!r}; known: {sorted(EFFECT_FORMS)}")
        if not isinstance(spec, dict) or set(spec) - {"form", "scale"} or "form" not in spec \
                or "scale" not in spec:
            raise ValueError(f"effects[{name!r}] must be {{'form': ..., 'scale': ...}}, got {spec!r}")
        if spec["form"] not in EFFECT_FORMS[name]:
            raise ValueError(f"effects[{name!r}] form {spec['form']!r} unknown; "
                             f"forms: {EFFECT_FORMS[name]}")
        s = spec["scale"]
        if isinstance(s, bool) or not isinstance(s, (int, float, np.integer, np.floating)) \
                or not math.isfinite(float(s)):
            raise ValueError(f"effects[{name!r}] scale must be a finite number, got {s!r}")
        if float(s) < 0.0 or float(s) > SCALE_MAX:
            raise ValueError(f"effects[{name!r}] scale must be in [0, SCALE_MAX={SCALE_MAX}], "
                             f"got {s!r}")
        if float(s) > 0.0:
            out[name] = {"form": spec["form"], "scale": float(s)}
    return out


def _quant(x: np.ndarray, step: float) -> np.ndarray:
    return x if step <= 0.0 else np.round(x / step) * step


def simulate_run(scheme: int, motor_speed_rpm: float | None, direction: int, temp_joint_c: float,
                 effects: dict[str, dict] | None = None, *, sensors: SensorSpec | None = None,
                 periods: int = 3, seed: int, run: int) -> RigRun:
    """Simulate one run of `scheme` on campaign `seed` (the machine), run number `run` (noise).

    Returns the run-format samples and metadata, the true states on the sample times and the
    parameters used. Deterministic in its arguments; effects at scale 0 are not applied."""
    eff = _validate(scheme, motor_speed_rpm, direction, temp_joint_c, effects, sensors, periods,
                    seed, run)
    sens = sensors if sensors is not None else SensorSpec()
    scheme, direction, periods = int(scheme), int(direction), int(periods)
    temp = float(temp_joint_c)
    camp = campaign_machine(int(seed))
    m, unst = camp["machine"], camp["unstated"]
    kernel_eff = {k: v for k, v in eff.items() if k not in SENSOR_EFFECTS}
    e, applied = _effect_vector(kernel_eff, m)
    for k in SENSOR_EFFECTS:
        if k in eff:
            applied[k] = dict(eff[k])
    tb, vb, ts, vs, dur, phases = _schedule(scheme, motor_speed_rpm, direction, periods)
    p = _pvec(m, scheme, direction)
    fs = sens.sample_rate_hz
    mult = max(1, int(round(1000.0 / fs)))
    dt_rec = 1.0 / (fs * mult)
    n_s = int(math.floor(dur * fs + 1e-9)) + 1
    n_rec = (n_s - 1) * mult + 1
    atol, rtol = _atol()
    y0 = _initial_state(m, temp)
    Y, A, nacc, nrej = _integrate(p, e, tb, vb, ts, vs, y0, dt_rec, n_rec, atol, rtol, 2e-6, 5e-3)
    if not np.all(np.isfinite(Y)):
        raise FloatingPointError("rig_u: the integration diverged")
    t_rec = np.arange(n_rec) * dt_rec
    idx = np.arange(n_s) * mult
    t = t_rec[idx]
    rng = np.random.default_rng(np.random.SeedSequence([int(seed), int(run), 0x55]))

    # --- true signals on the record grid -------------------------------------------------------
    q_r = Y[:, S_Q]
    phi_r = N2 * (Y[:, S_DEL] + q_r)
    theta_r = N1 * phi_r[:, None] + Y[:, S_D:S_D + 3]
    u_r = theta_r.mean(axis=1) / REDUCTION
    T_r = A[:, A_T]
    TL_r = A[:, A_TL]

    def lagged(x: np.ndarray, lag: float) -> np.ndarray:
        if lag <= 0.0:
            return x[idx]
        return np.interp(t - lag, t_rec, x)

    # --- hydraulics (bending moment and shear follow their set points, first order 0.8 s) ---
    if scheme == 3:
        mb = np.zeros(n_s)
        fsh = np.zeros(n_s)
    else:
        t_on, t_off = 2.5, (67.0 if scheme == 1 else 47.0)
        def fo(tt: np.ndarray) -> np.ndarray:
            up = np.where(tt >= t_on, 1.0 - np.exp(-(tt - t_on) / 0.8), 0.0)
            up_off = 1.0 - np.exp(-(t_off - t_on) / 0.8)
            return np.where(tt >= t_off, up_off * np.exp(-(tt - t_off) / 0.8), up)
        mb = 80e3 * fo(t)
        fsh = 90e3 * fo(t)
    p_hyd = mb / (0.01 * 0.5) + 0.3e6

    # --- readings -------------------------------------------------------------------------
    q_lag = 0.0
    tq_lag_eff = 0.0
    ld_lag_eff = 0.0
    if "time_delay" in eff:
        f, s = eff["time_delay"]["form"], eff["time_delay"]["scale"]
        if f == "torque":
            tq_lag_eff = 0.025 * s
        elif f == "q":
            q_lag = 1e-3 * s
        else:
            ld_lag_eff = 0.025 * s
    qres = sens.q_res_rad
    q_true_s = lagged(q_r, q_lag)
    interp = (unst["encoder_interp_amp_res"] * qres
              * np.sin(2 * math.pi * q_true_s / (unst["encoder_interp_period_res"] * qres)
                       + unst["encoder_interp_phase"]))
    q_read = q_true_s + interp
    u_extra = np.zeros(n_s)
    ld_extra = np.zeros(n_s)
    if "sensor_drift" in eff:
        f, s = eff["sensor_drift"]["form"], eff["sensor_drift"]["scale"]
        if f == "q_linear":
            q_read = q_read + 3e-5 * s * t / 60.0
        elif f == "load_linear":
            ld_extra = 250.0 * s * t / 60.0
        else:
            ph = m["wander_phase"]
            u_extra = 3e-5 * s * (np.sin(2 * math.pi * t / 47.0 + ph) - math.sin(ph))
    q_meas = _quant(q_read, qres)
    cres = 2.0 * math.pi / sens.motor_counts_per_rev
    th_meas = _quant(theta_r[idx], cres)
    u_meas = th_meas.mean(axis=1) / REDUCTION + u_extra
    # qd: offline central difference of the quantised encoder over +-25 ms on the record grid
    q_rec_meas = _quant(q_r + (unst["encoder_interp_amp_res"] * qres * np.sin(
        2 * math.pi * q_r / (unst["encoder_interp_period_res"] * qres) + unst["encoder_interp_phase"])), qres)
    if q_lag > 0.0:
        q_rec_meas = np.interp(t_rec - q_lag, t_rec, q_rec_meas)
    if "sensor_drift" in eff and eff["sensor_drift"]["form"] == "q_linear":
        q_rec_meas = _quant(q_rec_meas + 3e-5 * eff["sensor_drift"]["scale"] * t_rec / 60.0, qres)
    half = max(1, int(round(0.025 / dt_rec)))
    lo = np.clip(idx - half, 0, n_rec - 1)
    hi = np.clip(idx + half, 0, n_rec - 1)
    qd_meas = (q_rec_meas[hi] - q_rec_meas[lo]) / np.maximum(t_rec[hi] - t_rec[lo], dt_rec)

    tq_lag = sens.torque_lag_s + unst["torque_extra_lag_s"] + tq_lag_eff
    torque = lagged(T_r, tq_lag) + unst["torque_zero_offset_nm"] + unst["torque_bending_crosstalk"] * mb
    if "torque_offset" in eff:
        f, s = eff["torque_offset"]["form"], eff["torque_offset"]["scale"]
        if f == "constant":
            torque = torque + 250.0 * s
        elif f == "linear_drift":
            torque = torque + 250.0 * s * t / 60.0
        elif f == "exp_settle":
            torque = torque + 300.0 * s * (1.0 - np.exp(-t / 20.0))
        else:
            torque = torque + 0.003 * s * mb
    torque = _quant(torque + sens.torque_noise * rng.standard_normal(n_s), sens.torque_adc_step)
    tload = (1.0 + unst["load_cell_gain_error"]) * lagged(TL_r, sens.load_lag_s + ld_lag_eff) + ld_extra
    tload = _quant(tload + sens.load_noise * rng.standard_normal(n_s), sens.load_adc_step)
    cur = _quant(Y[idx, S_I:S_I + 3] + sens.current_noise * rng.standard_normal((n_s, 3)), sens.current_res)
    spd = _quant(Y[idx, S_W:S_W + 3] + sens.speed_noise * rng.standard_normal((n_s, 3)), 1e-3)
    tj = _quant(Y[idx, S_TG] + sens.temp_noise * rng.standard_normal(n_s), sens.temp_res)
    tw = _quant(Y[idx, S_TW:S_TW + 3] + sens.temp_noise * rng.standard_normal((n_s, 3)), sens.temp_res)
    phase = np.empty(n_s, dtype=object)
    for t0, name in phases:
        phase[t >= t0 - 1e-9] = name

    samples = pd.DataFrame({
        "t": t, "q": q_meas, "qd": qd_meas, "u": u_meas, "ud": spd.mean(axis=1) / REDUCTION,
        "torsion": q_meas - u_meas, "torque": torque, "torque_load": tload,
        "torque_cmd": A[idx, A_TCMD],
        "i_m1": cur[:, 0], "i_m2": cur[:, 1], "i_m3": cur[:, 2],
        "w_m1": spd[:, 0], "w_m2": spd[:, 1], "w_m3": spd[:, 2],
        "temp_m1": tw[:, 0], "temp_m2": tw[:, 1], "temp_m3": tw[:, 2],
        "temp_joint": tj,
        "p_hyd": p_hyd + 2e4 * rng.standard_normal(n_s),
        "m_bend": mb + 200.0 * rng.standard_normal(n_s),
        "f_shear": fsh + 200.0 * rng.standard_normal(n_s),
        "phase": phase,
    })
    truth = pd.DataFrame({
        "t": t, "q": q_r[idx], "qd": Y[idx, S_QD], "u": u_r[idx],
        "twist": u_r[idx] - q_r[idx], "twist_main": Y[idx, S_DEL],
        "torque": T_r[idx], "torque_load": TL_r[idx], "friction": A[idx, A_F],
        "sliding_level": A[idx, A_S], "gravity": A[idx, A_GRAV], "tau_extra": A[idx, A_TX],
        "temp_gear": Y[idx, S_TG], "temp_housing": Y[idx, S_TH], "brake_current": Y[idx, S_IE],
        "m_bend": mb,
    })
    s_meta = {
        "q": {"resolution": qres, "noise_sd": 0.0, "lag_s": 0.0},
        "u": {"resolution": sens.u_res_rad, "noise_sd": 0.0, "lag_s": 0.0},
        "torque": {"resolution": sens.torque_adc_step, "noise_sd": sens.torque_noise,
                   "lag_s": sens.torque_lag_s},
        "torque_load": {"resolution": sens.load_adc_step, "noise_sd": sens.load_noise,
                        "lag_s": sens.load_lag_s},
    }
    for k in (1, 2, 3):
        s_meta[f"i_m{k}"] = {"resolution": sens.current_res, "noise_sd": sens.current_noise, "lag_s": 0.0}
        s_meta[f"w_m{k}"] = {"resolution": 1e-3, "noise_sd": sens.speed_noise, "lag_s": 0.0}
        s_meta[f"temp_m{k}"] = {"resolution": sens.temp_res, "noise_sd": sens.temp_noise, "lag_s": 0.0}
    s_meta["temp_joint"] = {"resolution": sens.temp_res, "noise_sd": sens.temp_noise, "lag_s": 0.0}
    meta = {
        "scheme": scheme,
        "motor_speed_rpm": None if scheme == 3 else float(motor_speed_rpm),
        "direction": direction, "reduction": REDUCTION, "rig": RIG_NAME, "source": "emulator",
        "sample_rate_hz": fs, "started_at": "2026-01-05T09:00:00Z",
        "notes": f"validation rig U, campaign seed {int(seed)}, run {int(run)}",
        "sensors": s_meta,
        "units": {},
    }
    params = {
        "machine": m, "unstated": unst, "effects": applied,
        "run": {"scheme": scheme, "motor_speed_rpm": motor_speed_rpm, "direction": direction,
                "temp_joint_c": temp, "duration_s": dur, "periods": periods if scheme == 3 else None,
                "steps_accepted": int(nacc), "steps_rejected": int(nrej)},
    }
    return RigRun(samples=samples, meta=meta, truth=truth, params=params)
