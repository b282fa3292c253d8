"""Validation rig I -- an independent emulator of the CMOR J4 joint test platform.

DATA SHEET
==========

Written blind (from the rig description, the effect vocabulary and the source paper only) to
score a diagnosis on data it was never tuned on.  SI units throughout (angles in rad, torques
in N*m, speeds in rad/s) except temperatures (degC).  ``N = 11000`` is the total reduction.

Structure (output-referred coordinates; "output" = the joint's output flange)
-----------------------------------------------------------------------------
::

    3 servo motors --(one shaft, J_mot)--> reducer + differential planetary (N, compliant,
    stiffening, damped)  --[joint torque transducer T]-->  output body I (LuGre bearing,
    gravity)  --[load cell tau_L]-->  dynamometer (inertia J_d, own drag, torque loop)

States: q, qd (output); u, ud (motor angle / N); z (LuGre bristle); x (hysteresis state);
i_1..i_3 (motor currents); the speed-loop integral; the dynamometer torque and its rate; the
dynamometer's load-cell integral; q2, q2d (an extra mode, only for ``second_resonance``); an
8-operator play stack (``hysteresis/play_stack``); the two-node thermal model.

Laws
----
Twist and transmitted torque (the torque the transducer sees)::

    Delta   = u - q - e_k(u)                 (e_k: kinematic error, 0 nominally)
    Delta_b = dz(Delta)                      (backlash dead zone, identity nominally)
    T_el(d) = k2*d - (k2 - k1)*d_k*tanh(d/d_k)      stiffening: k1 at small twist -> k2
    T       = (1 - w_h)*T_el(Delta_b)*c(q) + w_h*k2*x + D*dDelta_b/dt
                                             (w_h = 0, c(q) = 1 nominally)

Output body and load cell (J_d, f_d only when the dynamometer is coupled: schemes 1, 2)::

    (I + J_d)*qdd = T - tau_dm - f_d(qd) - G(q) - F - T_x + R_2
    tau_L         = T - G(q) - F - T_x + R_2o - I*qdd   (= tau_dm + f_d + J_d*qdd - R_2d)
    G(q)          = g*(mr_x*sin q + mr_y*cos q),   g = 9.81
    T_x           = unmodelled torques on the joint side of the load cell (effects only)
    R_2           = m2*(w2^2*(q2 - q) + 2*zeta2*w2*(q2d - qd)), the reaction of an extra mode
                    (second_resonance only; R_2o if it hangs on the joint side, R_2d if behind
                    the load cell), q2dd = -R_2/m2

so ``I*qdd = T - tau_L - G - F - T_x + R_2o`` holds exactly on the truth (Eq. 4 plus the
load; the last two terms are zero on the nominal rig).

LuGre output-bearing friction (presliding, frictional lag and a little breakaway nominally)::

    g(v)  = F_c + (F_s0 - F_c)*exp(-(v/v_s0)^2)   [+ Stribeck effect term]
    dz/dt = v - sigma0*|v|*z/g(v)
    F     = sigma0*z + sigma1*exp(-(v/v_d)^2)*dz/dt + f_v*v
    steady sliding: F = g(v)*sgn(v) + f_v*v

Motor shaft (3 motors, torque constants k_t,j mismatched by a few %, output referred)::

    J_mot*N^2*udd = N*sum_j k_t,j*i_j - T*(1 - e_k'(u)) - N*(F_m*tanh(N*ud/0.5) + c_m*N*ud)
    di_j/dt       = (i_cmd - i_j)/tau_i,j            (current loops, first order)
    i_cmd         = tau_c/(3*k_t,nom),  |tau_c| <= tau_max   (torque saturation)

Drive control (designed on the data-sheet values, not on the drawn ones):

* schemes 1, 2 -- speed PI on the motor speed with acceleration feed-forward:
  ``tau_c = K_p*N*(w_ref - ud) + K_i*int(...) + J_mot*N*dw_ref/dt`` (anti-windup by
  conditional integration);
* scheme 3 -- position loop on the motor encoder with velocity and acceleration feed-forward:
  ``w_cmd = qd_ref + K_pos*(q_ref + u_0 - u)`` feeding the same speed PI.

Dynamometer (schemes 1, 2; scheme 3 runs with the dynamometer declutched, tau_L = 0)::

    tau_set   = (1 + eps_d)*tau_cmd + I_d ,  dI_d/dt = K_id*(tau_cmd - tau_L)
    tau_dm''  = w_d^2*(tau_set - tau_dm) - 2*zeta_d*w_d*tau_dm'     (torque loop)
    f_d(v)    = c_d*v + F_d*tanh(v/2e-4)                            (its own drag)

A positive ``tau_L`` resists positive motion; the dynamometer always loads against the
direction of motion: ``tau_cmd = direction * profile``.

Thermal (two nodes; the friction sees the lubricant node, the sensor sits on the housing)::

    C_o*dT_o/dt = P_loss - (T_o - T_h)/R_oh ,   P_loss = max(F*qd, 0) + D*dDelta_b^2 + 0.1*R_w*sum i^2
    C_h*dT_h/dt = (T_o - T_h)/R_oh - (T_h - T_amb)/R_ha ,   T_o(0) = T_h(0) = T_amb = temp_joint_c

Nominal parameters (drawn once per campaign ``seed``: each x (1 + U(-8 %, +8 %)))
------------------------------------------------------------------------------------
I 6685 kg m^2; mr_x 20.8 kg m; mr_y -34.5 kg m; f_v 8683 N m s/rad; F_c 2353 N m;
F_s0 = 1.05 F_c; v_s0 2e-5 rad/s; sigma0 5e7 N m/rad; sigma1 = 2*0.5*sqrt(sigma0*I);
v_d 5e-4 rad/s; k2 1.51e7 N m/rad; k1 = 0.55 k2; d_k 1.7e-3 rad (twist ~0.5 deg at 120 kN m);
D = 2*0.2*sqrt(k2*I) ~1.3e5 N m s/rad; J_mot 0.015 kg m^2 (3 x 0.004 + 0.003 reducer input);
k_t,nom 1.45 N m/A (each motor +-3 % about it); tau_i 0.8 ms; tau_max 16 N m (motor side,
~176 kN m at the output); F_m 0.06 N m; c_m 1.5e-4 N m s/rad; K_p 0.9 N m s/rad;
K_i 13.5 N m/rad; K_pos 12 1/s; J_d 3000 kg m^2; c_d 2000 N m s/rad; F_d 300 N m;
w_d 2*pi*6 rad/s; zeta_d 0.7; eps_d U(-1 %, 1 %); K_id 0.6 1/s; C_o 1.2e4 J/K; R_oh 0.02 K/W;
C_h 2.5e5 J/K; R_ha 0.05 K/W; R_w 0.8 ohm; temperature-sensor lag 8 s.
Effect constants that are "random" (ripple phases, disturbance frequencies, mode
frequencies) are also drawn from ``seed`` (a separate stream), never from ``run``.

Integrator
----------
Fixed-step classical RK4 with ``n_sub`` substeps per output sample, ``dt = 1/(fs*n_sub) <=
1/5000 s`` (5 kHz at 1 kHz sampling; 4 kHz and 20 kHz agree to 1 N m), compiled with numba.
The play stack is committed after each step (rate independent); the thermal nodes advance by
forward Euler at the same step.  The initial state is the static equilibrium at q = 0 (the
transmission holds gravity; bisection on u).  A non-finite state raises ``RuntimeError``
naming the active effects and scales.

Sensors (samples at ``t_k = k/fs``, fs in [10, 1000] Hz)
--------------------------------------------------------
* ``q``: absolute output encoder, round-to-step quantisation at ``encoder_res_deg``.
* ``qd``: velocity from the quantised output encoder through a type-2 tracking loop
  (bandwidth 3 Hz, zero DC group delay; quantisation noise only).
* ``u``: motor encoder, 20 bit per motor revolution (step 2*pi/2^20/N).
* ``ud``, ``w_m1..3``: drive speed readings, first-order 2 ms filter + 0.03 rad/s noise per
  drive (motor side); ``ud`` is their mean / N.
* ``torque``: joint torque transducer: 2nd-order Butterworth 100 Hz (DC group delay
  sqrt(2)/(2*pi*100) = 2.25 ms) -> the stated extra lag ``torque_lag_s`` (pure or first
  order) -> [effects] -> white noise ``torque_noise`` -> 16-bit ADC on +-200 kN m (6.1 N m).
* ``torque_load``: load cell, Butterworth 30 Hz (7.5 ms) -> 60 N m noise -> 7.63 N m step.
* ``i_m1..3``: currents + 0.02 A noise, 0.005 A step; ``temp_joint``: housing Pt100, 8 s lag,
  0.03 degC noise, 0.1 degC step.
``meta["sensors"]`` states these per channel (resolution, noise_sd, lag_s, unit).
``SensorSpec`` sets the rate, the encoder step, the torque noise and stated lag (and its kind,
``torque_lag_kind`` "pure" or "first_order"), and the other channels' noise levels.

Effects ``{name: {"form": f, "scale": s}}``, s finite >= 0 (s = 0 is the nominal rig bit for
bit; s = 1 clearly visible yet realistic; linear in s for small s; clamped at large s; a
missing "form" means the effect's first form; anything else unknown raises ValueError)
-----------------------------------------------------------------------------------------
stribeck -- extra term ``dF*phi(|v|/v_s)`` in g(v); ``dF = 0.4*F_c*s`` (s clamped to 5),
  v_s = 1.5e-3 rad/s (x draw, ~5 % of top speed):
  exponential ``phi = exp(-x)``; gaussian ``exp(-x^2)``; lorentzian ``1/(1+x^2)``;
  stretched ``exp(-sqrt(x))`` (own form, exponent 0.5).
temperature_friction -- dT = 25 degC - T_o (lubricant):
  additive ``F_c += 0.008*s*F_c*dT, f_v += 0.02*s*f_v*dT`` (each floored at 0.2x);
  exponential ``g, f_v *= exp(clip(0.015*s*dT, -1.5, 1.5))`` (all friction);
  viscous_only ``f_v *= max(0.2, 1 + 0.03*s*dT)``.
load_dependent_friction -- coulomb ``F_c += 0.015*s*|T|``; coulomb_viscous
  ``F_c += 0.010*s*|T|, f_v *= 1 + 0.8*s*|T|/120 kN m`` (s clamped to 10).
asymmetric_friction -- sigma = tanh(v/2e-5): coulomb ``F_c *= 1 + 0.12*s*sigma``;
  viscous ``f_v *= 1 + 0.30*s*sigma``; both (both terms); each 0.12*s, 0.30*s clamped to 0.8.
gear_ripple -- (s clamped to 10)
  output_angle ``T_x += 600*s*(0.4 + 0.6*min(|T|/120 kN m, 2))*sum_h c_h sin(h*117*q + p_h)``,
  c = (1, 0.45, 0.2) (output-stage mesh, amplitude growing with load);
  motor_angle ``T_x += 400*s*(sin(1100*u + p_1) + 0.35*sin(2200*u + p_2))`` (an intermediate
  stage's tooth passing, locked to the motor angle: 0.1 cycle per motor revolution);
  kinematic_error ``e_k(u) = 3e-4*s*(sin(58*u + p_1) + 0.3*sin(116*u + p_2))`` rad.
backlash -- half gap b = 6e-4*s rad (~2 arcmin at s = 1; s clamped to 8):
  sharp ``dz = Delta - b*sgn(Delta)`` outside |Delta| <= b, 0 inside;
  smooth ``dz = eps*[sp((Delta-b)/eps) - sp((-Delta-b)/eps)]``, sp = softplus, eps = 0.3*b.
hysteresis -- w_h = 0.15*s (clamped to 0.8), x_m = 1.2e-3 rad (loop half height
  w_h*k2*x_m ~ 2.7 kN m at s = 1):
  bouc_wen_n1 ``dx = dD - 0.7/x_m*|dD|*x - 0.3/x_m*dD*|x|``;
  bouc_wen_n2 ``dx = dD - 0.7/x_m^2*|dD|*|x|*x - 0.3/x_m^2*dD*x^2``;
  dahl ``dx = dD*|r|^1.5*sgn(r), r = 1 - sgn(dD)*x/x_m``;
  play_stack ``x = mean_j (Delta_b - p_j)``, p_j play operators of radius r_j =
  2*x_m*(j+1/2)/8, j = 0..7 (a Maxwell-slip / Prandtl-Ishlinskii stack).
torque_offset -- on the torque reading: constant ``+600*s`` N m; drift ``+12*s*t`` N m.
time_delay -- on the torque reading, unstated: pure ``delay 0.015*s`` s; first_order
  ``lag 0.02*s`` s (both clamped to 0.5 s).
Out of vocabulary (``OUT_OF_VOCABULARY``):
periodic_disturbance -- sine ``T_x += 500*s*sin(2*pi*f*t + p)``, f in [0.8, 1.4] Hz;
  pulses ``T_x += 700*s*(pulse train, Gaussian 60 ms wide, period 1/f, f in [0.5, 0.8] Hz,
  mean removed)`` (a hydraulic pump).
position_dependent_stiffness -- T_el *= c(q): cosine ``c = 1 + 0.2*s*cos(2q + p)``
  (0.2*s clamped to 0.7); linear ``c = max(0.3, 1 + 0.3*s*q/(pi/2))`` (0.3*s clamped to 3).
sensor_drift -- load_cell ``tau_L reading += 10*s*t`` N m; output_encoder
  ``q reading += 2.5e-5*s*t`` rad (a slipping encoder coupling, before quantisation).
second_resonance -- an extra mass m2 on a spring, frequency f2, damping 2-3 %:
  output_mode m2 = 0.5*s*I at f2 in [8, 11] Hz on the joint side of the load cell;
  dyno_mode m2 = 1.0*s*J_d at f2 in [2.5, 3.5] Hz behind the load cell (seen in tau_L;
  nothing in scheme 3 where the dynamometer is declutched).  s clamped to 5.

Schemes
-------
1. rest 1 s, accelerate 2 s (raised cosine) to ``direction*rpm*2*pi/60/N``, hold 3 s,
   load 0 -> 120 kN m in 24 s (linear), hold 1 s, unload in 24 s, hold 1 s, decelerate 2 s,
   rest 1 s: 59 s.
2. rest 1, accelerate 2, hold 2, 12 x (load +10 kN m in 0.15 s raised cosine, hold 2 s),
   6 x (unload -20 kN m in 0.15 s, hold 1.85 s), decelerate 2, rest 1: 45.8 s.
3. no load, dynamometer declutched: rest 1 s, ``periods`` periods of the Eq. 12 fifth-order
   Fourier trajectory (w_f = 2*pi/20 s, |qd| <= 0.9 x the 3000 r/min speed, +-1.5 deg,
   starting and ending at rest: sum a_l = 0, sum l*b_l = 0), rest 1 s.
"""


import math
from dataclasses import dataclass

import numba
import numpy as np
import pandas as pd

SEED_IS_CAMPAIGN = True
REDUCTION = 11000.0
RIG_NAME = "validation-rig-I"

EFFECT_FORMS: dict[str, tuple[str, ...]] = {
    "stribeck": ("exponential", "gaussian", "lorentzian", "stretched"),
    "temperature_friction": ("additive", "exponential", "viscous_only"),
    "load_dependent_friction": ("coulomb", "coulomb_viscous"),
    "asymmetric_friction": ("coulomb", "viscous", "both"),
    "gear_ripple": ("output_angle", "motor_angle", "kinematic_error"),
    "backlash": ("sharp", "smooth"),
    "hysteresis": ("bouc_wen_n1", "bouc_wen_n2", "dahl", "play_stack"),
    "torque_offset": ("constant", "drift"),
    "time_delay": ("pure", "first_order"),
    "periodic_disturbance": ("sine", "pulses"),
    "position_dependent_stiffness": ("cosine", "linear"),
    "sensor_drift": ("load_cell", "output_encoder"),
    "second_resonance": ("output_mode", "dyno_mode"),
}
OUT_OF_VOCABULARY: tuple[str, ...] = (
    "periodic_disturbance",
    "position_dependent_stiffness",
    "sensor_drift",
    "second_resonance",
)

# the largest scale each effect responds to (physical saturation, documented above)
_SCALE_CLAMP = {
    "stribeck": 5.0,
    "temperature_friction": 20.0,
    "load_dependent_friction": 10.0,
    "asymmetric_friction": 1.0e9,  # clamped per coefficient (0.8)
    "gear_ripple": 10.0,
    "backlash": 8.0,
    "hysteresis": 0.8 / 0.15,
    "torque_offset": 50.0,
    "time_delay": 1.0e9,  # clamped on the delay (0.5 s)
    "periodic_disturbance": 10.0,
    "position_dependent_stiffness": 1.0e9,  # clamped on the coefficient
    "sensor_drift": 50.0,
    "second_resonance": 5.0,
}

N_GEAR = REDUCTION
T_RATED = 120.0e3
T_REF_C = 25.0
G_ACC = 9.81
DT_MAX = 1.0 / 5000.0
N_PLAY = 8
U_STEP = 2.0 * math.pi / 2.0**20 / REDUCTION
TORQUE_ADC = 400.0e3 / 2.0**16
LOAD_ADC = 500.0e3 / 2.0**16
TORQUE_FILTER_HZ = 100.0
LOAD_FILTER_HZ = 30.0
LOAD_NOISE = 60.0
SPEED_FILTER_S = 0.002
SPEED_NOISE = 0.03
CURRENT_NOISE = 0.02
CURRENT_STEP = 0.005
TEMP_NOISE = 0.03
TEMP_STEP = 0.1
TEMP_LAG_S = 8.0
TRACK_HZ = 3.0

# Eq. 12 coefficients (rad/s), chosen offline for a low condition number of the column-scaled
# Eq. 4 regressor within the speed limit; the constraints are re-imposed in _fourier_coeffs.
_FOURIER_A = (-0.00107397, -0.00252929, 0.00405843, 0.00410567, -0.00456085)
_FOURIER_B = (0.00391711, -0.00614586, -0.00240127, 0.00566631, -0.00141737)
_FOURIER_PERIOD = 20.0

_CACHE = __name__ == "validation_rigs.rig_i"


def _jit(f):
    return numba.njit(cache=_CACHE)(f)


# ---------------------------------------------------------------- parameter vector layout
P_I, P_MRX, P_MRY, P_FV, P_FC, P_FS, P_VS0, P_SIG0, P_SIG1, P_VD = range(10)
P_K1, P_K2, P_DK, P_DT, P_JMOT, P_KT1, P_KT2, P_KT3, P_KTN, P_MCF = range(10, 20)
P_MCV, P_KP, P_KI, P_TI1, P_TI2, P_TI3, P_TMAX, P_KPOS, P_JD, P_CD = range(20, 30)
P_FD, P_WD, P_ZD, P_GERR, P_KID, P_COUPLED, P_CO, P_ROH, P_CH, P_RHA = range(30, 40)
P_TAMB, P_RW, P_UOFF = range(40, 43)
NP = 43

E_STR_F, E_STR_DF, E_STR_VS = 0, 1, 2
E_TMP_F, E_TMP_S = 3, 4
E_LD_F, E_LD_MUC, E_LD_MUV = 5, 6, 7
E_AS_C, E_AS_V = 8, 9
E_RQ_A, E_RQ_Z, E_RQ_P1, E_RQ_P2, E_RQ_P3 = 10, 11, 12, 13, 14
E_RM_A, E_RM_Z, E_RM_P1, E_RM_P2 = 15, 16, 17, 18
E_KE_A, E_KE_Z, E_KE_P1, E_KE_P2 = 19, 20, 21, 22
E_BL_F, E_BL_B = 23, 24
E_HY_F, E_HY_W, E_HY_XM = 25, 26, 27
E_PDS_F, E_PDS_A, E_PDS_P = 28, 29, 30
E_PD_F, E_PD_A, E_PD_FR, E_PD_P, E_PD_W = 31, 32, 33, 34, 35
E_SR_F, E_SR_M, E_SR_W, E_SR_Z = 36, 37, 38, 39
E_TREF = 40
NE = 41

NAUX = 12  # T, tauL, F, G, qdd, dDelta_b, T_x, P_loss, tau_cmd, Delta_b, motor torque, z-rate
NREC = 15 + NAUX


# ---------------------------------------------------------------- compiled model
@_jit
def _sched(t, seg, k):
    n = seg.shape[0]
    while k < n - 1 and t >= seg[k, 1]:
        k += 1
    t0 = seg[k, 0]
    t1 = seg[k, 1]
    x = (t - t0) / (t1 - t0)
    if x < 0.0:
        x = 0.0
    elif x > 1.0:
        x = 1.0
    if seg[k, 2] == 0.0:
        s = x
        ds = 1.0 / (t1 - t0)
        if t < t0 or t > t1:
            ds = 0.0
    else:
        s = 0.5 * (1.0 - math.cos(math.pi * x))
        ds = 0.5 * math.pi * math.sin(math.pi * x) / (t1 - t0)
    w = seg[k, 3] + (seg[k, 4] - seg[k, 3]) * s
    a = (seg[k, 4] - seg[k, 3]) * ds
    load = seg[k, 5] + (seg[k, 6] - seg[k, 5]) * s
    return w, a, load, k


@_jit
def _fourier(tau, fa, fb, wf):
    q = 0.0
    qd = 0.0
    qdd = 0.0
    q0 = 0.0
    for l in range(fa.shape[0]):
        wl = wf * (l + 1)
        sn = math.sin(wl * tau)
        cs = math.cos(wl * tau)
        q += fa[l] / wl * sn - fb[l] / wl * cs
        q0 += fb[l] / wl
        qd += fa[l] * cs + fb[l] * sn
        qdd += -fa[l] * wl * sn + fb[l] * wl * cs
    return q + q0, qd, qdd


@_jit
def _softplus(x):
    if x > 30.0:
        return x
    if x < -30.0:
        return math.exp(x)
    return math.log1p(math.exp(x))


@_jit
def _sigmoid(x):
    if x >= 0.0:
        return 1.0 / (1.0 + math.exp(-x))
    e = math.exp(x)
    return e / (1.0 + e)


@_jit
def _twist(q, u, ud, v, E):
    """Effective twist after kinematic error and backlash, its rate, and e_k'(u)."""
    ke = 0.0
    ked = 0.0
    if E[E_KE_A] > 0.0:
        a = E[E_KE_A]
        zk = E[E_KE_Z]
        p1 = zk * u + E[E_KE_P1]
        p2 = 2.0 * zk * u + E[E_KE_P2]
        ke = a * (math.sin(p1) + 0.3 * math.sin(p2))
        ked = a * zk * (math.cos(p1) + 0.6 * math.cos(p2))
    dl = u - q - ke
    dld = ud * (1.0 - ked) - v
    bf = E[E_BL_F]
    if bf == 1.0:
        b = E[E_BL_B]
        if dl > b:
            db = dl - b
            dbd = dld
        elif dl < -b:
            db = dl + b
            dbd = dld
        else:
            db = 0.0
            dbd = 0.0
    elif bf == 2.0:
        b = E[E_BL_B]
        eps = 0.3 * b
        db = eps * (_softplus((dl - b) / eps) - _softplus((-dl - b) / eps))
        dbd = dld * (_sigmoid((dl - b) / eps) + _sigmoid((-dl - b) / eps))
    else:
        db = dl
        dbd = dld
    return db, dbd, ked, dl


@_jit
def _elastic(db, q, P, E):
    k1 = P[P_K1]
    k2 = P[P_K2]
    dk = P[P_DK]
    tel = k2 * db - (k2 - k1) * dk * math.tanh(db / dk)
    pf = E[E_PDS_F]
    if pf == 1.0:
        tel *= 1.0 + E[E_PDS_A] * math.cos(2.0 * q + E[E_PDS_P])
    elif pf == 2.0:
        c = 1.0 + E[E_PDS_A] * q / (0.5 * math.pi)
        if c < 0.3:
            c = 0.3
        tel *= c
    return tel


@_jit
def _play_x(db, play, xm):
    x = 0.0
    for j in range(play.shape[0]):
        r = 2.0 * xm * (j + 0.5) / play.shape[0]
        p = play[j]
        if p < db - r:
            p = db - r
        elif p > db + r:
            p = db + r
        x += db - p
    return x / play.shape[0]


@_jit
def _rhs(t, y, dy, aux, P, E, seg, k0, fa, fb, wf, tex0, tex1, scheme, toil, play):
    n = 11000.0
    q = y[0]
    v = y[1]
    u = y[2]
    ud = y[3]
    z = y[4]
    xh = y[5]
    i1 = y[6]
    i2 = y[7]
    i3 = y[8]
    iw = y[9]
    td = y[10]
    tdd = y[11]
    idy = y[12]
    q2 = y[13]
    q2d = y[14]

    # ---- references and drive control
    wref, aref, lcmd, k = _sched(t, seg, k0)
    if scheme == 3:
        qr = 0.0
        qdr = 0.0
        qddr = 0.0
        if t > tex0 and t < tex1:
            qr, qdr, qddr = _fourier(t - tex0, fa, fb, wf)
        udc = qdr + P[P_KPOS] * (P[P_UOFF] + qr - u)
        aff = qddr
    else:
        udc = wref
        aff = aref
    e = n * (udc - ud)
    tc = P[P_KP] * e + P[P_KI] * iw + P[P_JMOT] * n * aff
    diw = e
    tmax = P[P_TMAX]
    if tc > tmax:
        tc = tmax
        if e > 0.0:
            diw = 0.0
    elif tc < -tmax:
        tc = -tmax
        if e < 0.0:
            diw = 0.0
    icmd = tc / (3.0 * P[P_KTN])

    # ---- transmission
    db, dbd, ked, dl = _twist(q, u, ud, v, E)
    tel = _elastic(db, q, P, E)
    hf = E[E_HY_F]
    dxh = 0.0
    if hf == 0.0:
        tt = tel + P[P_DT] * dbd
    else:
        w = E[E_HY_W]
        xm = E[E_HY_XM]
        xe = xh
        if hf == 1.0:
            dxh = dbd - (0.7 / xm) * abs(dbd) * xh - (0.3 / xm) * dbd * abs(xh)
        elif hf == 2.0:
            dxh = dbd - (0.7 / (xm * xm)) * abs(dbd) * abs(xh) * xh - (0.3 / (xm * xm)) * dbd * xh * xh
        elif hf == 3.0:
            sg = 1.0 if dbd >= 0.0 else -1.0
            r = 1.0 - sg * xh / xm
            if r >= 0.0:
                dxh = dbd * r * math.sqrt(r)
            else:
                dxh = -dbd * (-r) * math.sqrt(-r)
        else:
            xe = _play_x(db, play, xm)
        tt = (1.0 - w) * tel + w * P[P_K2] * xe + P[P_DT] * dbd

    # ---- output-bearing friction (LuGre)
    fc = P[P_FC]
    fv = P[P_FV]
    dfs = P[P_FS] - P[P_FC]
    tf = E[E_TMP_F]
    ts = E[E_TMP_S]
    dtemp = E[E_TREF] - toil
    if tf == 1.0:
        fc = max(0.2 * fc, fc + ts * 0.008 * P[P_FC] * dtemp)
        fv = max(0.2 * fv, fv + ts * 0.02 * P[P_FV] * dtemp)
    elif tf == 3.0:
        fv = fv * max(0.2, 1.0 + ts * 0.03 * dtemp)
    lf = E[E_LD_F]
    if lf > 0.0:
        at = abs(tt)
        fc += E[E_LD_MUC] * at
        fv *= 1.0 + E[E_LD_MUV] * at / 120.0e3
    if E[E_AS_C] > 0.0 or E[E_AS_V] > 0.0:
        sgv = math.tanh(v / 2.0e-5)
        fc *= 1.0 + E[E_AS_C] * sgv
        fv *= 1.0 + E[E_AS_V] * sgv
    xv = v / P[P_VS0]
    g = fc + dfs * math.exp(-xv * xv)
    sf = E[E_STR_F]
    if sf > 0.0:
        xs = abs(v) / E[E_STR_VS]
        if sf == 1.0:
            phi = math.exp(-xs)
        elif sf == 2.0:
            phi = math.exp(-xs * xs)
        elif sf == 3.0:
            phi = 1.0 / (1.0 + xs * xs)
        else:
            phi = math.exp(-math.sqrt(xs))
        g += E[E_STR_DF] * phi
    if tf == 2.0:
        ex = ts * 0.015 * dtemp
        if ex > 1.5:
            ex = 1.5
        elif ex < -1.5:
            ex = -1.5
        m = math.exp(ex)
        g *= m
        fv *= m
    if g < 1.0:
        g = 1.0
    zd = v - P[P_SIG0] * abs(v) * z / g
    xd = v / P[P_VD]
    ff = P[P_SIG0] * z + P[P_SIG1] * math.exp(-xd * xd) * zd + fv * v

    # ---- gravity and unmodelled torques on the joint side of the load cell
    gr = G_ACC * (P[P_MRX] * math.sin(q) + P[P_MRY] * math.cos(q))
    tx = 0.0
    if E[E_RQ_A] > 0.0:
        lr = abs(tt) / 120.0e3
        if lr > 2.0:
            lr = 2.0
        ph = E[E_RQ_Z] * q
        tx += E[E_RQ_A] * (0.4 + 0.6 * lr) * (
            math.sin(ph + E[E_RQ_P1]) + 0.45 * math.sin(2.0 * ph + E[E_RQ_P2])
            + 0.2 * math.sin(3.0 * ph + E[E_RQ_P3]))
    if E[E_RM_A] > 0.0:
        ph = E[E_RM_Z] * u
        tx += E[E_RM_A] * (math.sin(ph + E[E_RM_P1]) + 0.35 * math.sin(2.0 * ph + E[E_RM_P2]))
    pf = E[E_PD_F]
    if pf == 1.0:
        tx += E[E_PD_A] * math.sin(2.0 * math.pi * E[E_PD_FR] * t + E[E_PD_P])
    elif pf == 2.0:
        per = 1.0 / E[E_PD_FR]
        wd_ = E[E_PD_W]
        tau = (t + E[E_PD_P] * per / (2.0 * math.pi)) % per
        xx = (tau - 0.5 * per) / wd_
        tx += E[E_PD_A] * (math.exp(-0.5 * xx * xx) - wd_ * math.sqrt(2.0 * math.pi) / per)

    coupled = P[P_COUPLED] > 0.5
    srf = E[E_SR_F]
    rr = 0.0
    dq2 = 0.0
    dq2d = 0.0
    if srf == 1.0 or (srf == 2.0 and coupled):
        w2 = E[E_SR_W]
        z2 = E[E_SR_Z]
        acc2 = -w2 * w2 * (q2 - q) - 2.0 * z2 * w2 * (q2d - v)
        rr = -E[E_SR_M] * acc2
        dq2 = q2d
        dq2d = acc2
    r_out = rr if srf == 1.0 else 0.0

    if coupled:
        fd = P[P_CD] * v + P[P_FD] * math.tanh(v / 2.0e-4)
        tset = (1.0 + P[P_GERR]) * lcmd + idy
        dtd = tdd
        dtdd = P[P_WD] * P[P_WD] * (tset - td) - 2.0 * P[P_ZD] * P[P_WD] * tdd
        qdd = (tt - td - fd - gr - ff - tx + rr) / (P[P_I] + P[P_JD])
        taul = tt - gr - ff - tx + r_out - P[P_I] * qdd
        didy = P[P_KID] * (lcmd - taul)
    else:
        dtd = 0.0
        dtdd = 0.0
        didy = 0.0
        qdd = (tt - gr - ff - tx + rr) / P[P_I]
        taul = 0.0

    # ---- motor shaft
    wm = n * ud
    tfm = P[P_MCF] * math.tanh(wm / 0.5) + P[P_MCV] * wm
    tm = P[P_KT1] * i1 + P[P_KT2] * i2 + P[P_KT3] * i3
    udd = (n * tm - tt * (1.0 - ked) - n * tfm) / (P[P_JMOT] * n * n)

    dy[0] = v
    dy[1] = qdd
    dy[2] = ud
    dy[3] = udd
    dy[4] = zd
    dy[5] = dxh
    dy[6] = (icmd - i1) / P[P_TI1]
    dy[7] = (icmd - i2) / P[P_TI2]
    dy[8] = (icmd - i3) / P[P_TI3]
    dy[9] = diw
    dy[10] = dtd
    dy[11] = dtdd
    dy[12] = didy
    dy[13] = dq2
    dy[14] = dq2d

    ploss = ff * v
    if ploss < 0.0:
        ploss = 0.0
    ploss += P[P_DT] * dbd * dbd + 0.1 * P[P_RW] * (i1 * i1 + i2 * i2 + i3 * i3)
    aux[0] = tt
    aux[1] = taul
    aux[2] = ff
    aux[3] = gr
    aux[4] = qdd
    aux[5] = dbd
    aux[6] = tx
    aux[7] = ploss
    aux[8] = lcmd
    aux[9] = db
    aux[10] = tm
    aux[11] = zd
    return k


@_jit
def _static_torque(u, P, E, play):
    db, dbd, ked, dl = _twist(0.0, u, 0.0, 0.0, E)
    tel = _elastic(db, 0.0, P, E)
    if E[E_HY_F] == 0.0:
        return tel
    w = E[E_HY_W]
    if E[E_HY_F] == 4.0:
        for j in range(play.shape[0]):
            play[j] = db
    return (1.0 - w) * tel


@_jit
def _equilibrium(P, E, play):
    target = G_ACC * P[P_MRY]  # gravity at q = 0
    lo = -0.05
    hi = 0.05
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        if _static_torque(mid, P, E, play) < target:
            lo = mid
        else:
            hi = mid
    u0 = 0.5 * (lo + hi)
    db, dbd, ked, dl = _twist(0.0, u0, 0.0, 0.0, E)
    for j in range(play.shape[0]):
        play[j] = db
    return u0


@_jit
def _integrate(P, E, seg, fa, fb, wf, tex0, tex1, scheme, n_samples, n_sub, dt,
               y, play, toil0, fine_t, fine_l, fine_q, fine_ud, rec):
    ny = y.shape[0]
    k1 = np.empty(ny)
    k2 = np.empty(ny)
    acc = np.empty(ny)
    yt = np.empty(ny)
    aux = np.empty(NAUX)
    aux2 = np.empty(NAUX)
    toil = toil0
    thou = toil0
    tamb = P[P_TAMB]
    n_fine = (n_samples - 1) * n_sub + 1
    kseg = 0
    xm = E[E_HY_XM]
    for j in range(n_fine):
        t = j * dt
        kseg = _rhs(t, y, k1, aux, P, E, seg, kseg, fa, fb, wf, tex0, tex1, scheme, toil, play)
        fine_t[j] = aux[0]
        fine_l[j] = aux[1]
        fine_q[j] = y[0]
        fine_ud[j] = y[3]
        if j % n_sub == 0:
            ks = j // n_sub
            for c in range(15):
                rec[ks, c] = y[c]
            for c in range(NAUX):
                rec[ks, 15 + c] = aux[c]
            rec[ks, 15 + 7] = toil  # replace P_loss by the lubricant temperature
            rec[ks, 15 + 11] = thou  # replace the z-rate by the housing temperature
            ok = True
            for c in range(15):
                if not math.isfinite(y[c]):
                    ok = False
            if not math.isfinite(aux[0]) or not math.isfinite(aux[1]) or not math.isfinite(toil):
                ok = False
            if not ok:
                return ks
        if j == n_fine - 1:
            break
        # RK4 stages 2-4 through one call site (keeps the compiled kernel small)
        for c in range(ny):
            acc[c] = k1[c]
        kk = k1
        for st in range(3):
            hs = 0.5 * dt if st < 2 else dt
            wgt = 2.0 if st < 2 else 1.0
            for c in range(ny):
                yt[c] = y[c] + hs * kk[c]
            _rhs(t + hs, yt, k2, aux2, P, E, seg, kseg, fa, fb, wf, tex0, tex1, scheme, toil, play)
            for c in range(ny):
                acc[c] += wgt * k2[c]
            kk = k2
        for c in range(ny):
            y[c] = y[c] + dt / 6.0 * acc[c]
        if E[E_HY_F] == 4.0:
            db, dbd, ked, dl = _twist(y[0], y[2], y[3], y[1], E)
            m = play.shape[0]
            for i in range(m):
                r = 2.0 * xm * (i + 0.5) / m
                if play[i] < db - r:
                    play[i] = db - r
                elif play[i] > db + r:
                    play[i] = db + r
        # thermal nodes (forward Euler)
        pl = aux[7]
        qoh = (toil - thou) / P[P_ROH]
        toil += dt * (pl - qoh) / P[P_CO]
        thou += dt * (qoh - (thou - tamb) / P[P_RHA]) / P[P_CH]
    return -1


@_jit
def _lpf2(x, fc, dt):
    """2nd-order Butterworth low-pass (bilinear, prewarped), started at steady state."""
    wc = math.tan(math.pi * fc * dt)
    k = wc * wc
    r2 = math.sqrt(2.0)
    a0 = 1.0 + r2 * wc + k
    b0 = k / a0
    b1 = 2.0 * k / a0
    b2 = k / a0
    a1 = 2.0 * (k - 1.0) / a0
    a2 = (1.0 - r2 * wc + k) / a0
    out = np.empty_like(x)
    x1 = x[0]
    x2 = x[0]
    y1 = x[0]
    y2 = x[0]
    for i in range(x.shape[0]):
        yy = b0 * x[i] + b1 * x1 + b2 * x2 - a1 * y1 - a2 * y2
        x2 = x1
        x1 = x[i]
        y2 = y1
        y1 = yy
        out[i] = yy
    return out


@_jit
def _lag1(x, tau, dt):
    """First-order lag tau*dy/dt = x - y, exact for a piecewise-linear input (so that its
    delay on a ramp is tau exactly, for any tau, even below dt)."""
    out = np.empty_like(x)
    e = math.exp(-dt / tau)
    c = tau / dt * (1.0 - e)
    s = x[0]
    out[0] = s
    for i in range(1, x.shape[0]):
        s = e * s + x[i] - e * x[i - 1] - c * (x[i] - x[i - 1])
        out[i] = s
    return out


@_jit
def _sample(x, n_sub, n_samples, delay_steps):
    out = np.empty(n_samples)
    for k in range(n_samples):
        pos = k * n_sub - delay_steps
        if pos <= 0.0:
            out[k] = x[0]
            continue
        i0 = int(math.floor(pos))
        fr = pos - i0
        if i0 >= x.shape[0] - 1:
            out[k] = x[x.shape[0] - 1]
        elif fr == 0.0:
            out[k] = x[i0]
        else:
            out[k] = x[i0] * (1.0 - fr) + x[i0 + 1] * fr
    return out


@_jit
def _track_velocity(qf, dt, step, drift_rate, n_sub, n_samples, wbw, quantise):
    """Type-2 tracking loop on the quantised (and possibly drifting) output encoder."""
    out = np.empty(n_samples)
    xh = qf[0]
    vh = 0.0
    for j in range(qf.shape[0]):
        qm = qf[j] + drift_rate * j * dt
        if quantise:
            qm = step * math.floor(qm / step + 0.5)
        if j == 0:
            xh = qm
        if j % n_sub == 0:
            out[j // n_sub] = vh
        e = qm - xh
        xh += dt * (vh + 2.0 * wbw * e)
        vh += dt * wbw * wbw * e
    return out


# ---------------------------------------------------------------- python side
@dataclass(frozen=True)
class SensorSpec:
    sample_rate_hz: float = 1000.0
    encoder_res_deg: float = 0.01
    torque_noise: float = 150.0
    torque_lag_s: float = 0.0
    torque_lag_kind: str = "pure"  # "pure" or "first_order": how torque_lag_s acts
    load_noise: float = LOAD_NOISE
    current_noise: float = CURRENT_NOISE
    speed_noise: float = SPEED_NOISE
    temp_noise: float = TEMP_NOISE


@dataclass
class RigRun:
    samples: pd.DataFrame
    meta: dict
    truth: pd.DataFrame


def _u64(x: int) -> int:
    return int(x) & 0xFFFFFFFFFFFFFFFF


def nominal_parameters(seed: int) -> dict:
    """The campaign's drawn nominal parameters (physical names, SI)."""
    rng = np.random.default_rng(np.random.SeedSequence([_u64(seed), 0x4A4], spawn_key=(1,)))

    def d(x):
        return float(x * (1.0 + rng.uniform(-0.08, 0.08)))

    p = {}
    p["I"] = d(6685.0)
    p["mr_x"] = d(20.8)
    p["mr_y"] = d(-34.5)
    p["f_v"] = d(8683.0)
    p["F_c"] = d(2353.0)
    p["F_s0"] = p["F_c"] * d(1.05)
    if p["F_s0"] < p["F_c"]:
        p["F_s0"] = p["F_c"]
    p["v_s0"] = d(2.0e-5)
    p["sigma0"] = d(5.0e7)
    p["sigma1"] = 2.0 * d(0.5) * math.sqrt(p["sigma0"] * p["I"])
    p["v_d"] = d(5.0e-4)
    p["k2"] = d(1.51e7)
    p["k1"] = p["k2"] * d(0.55)
    p["d_k"] = d(1.7e-3)
    p["D"] = 2.0 * d(0.2) * math.sqrt(p["k2"] * p["I"])
    p["J_mot"] = 3.0 * d(0.004) + d(0.003)
    p["k_t_nom"] = 1.45
    p["k_t"] = [float(1.45 * (1.0 + rng.uniform(-0.03, 0.03))) for _ in range(3)]
    p["F_m"] = d(0.06)
    p["c_m"] = d(1.5e-4)
    p["tau_i"] = [d(0.8e-3) for _ in range(3)]
    p["tau_max"] = 16.0
    p["K_p"] = 0.9
    p["K_i"] = 13.5
    p["K_pos"] = 12.0
    p["J_d"] = d(3000.0)
    p["c_d"] = d(2000.0)
    p["F_d"] = d(300.0)
    p["w_d"] = d(2.0 * math.pi * 6.0)
    p["zeta_d"] = d(0.7)
    p["eps_d"] = float(rng.uniform(-0.01, 0.01))
    p["K_id"] = d(0.6)
    p["C_o"] = d(1.2e4)
    p["R_oh"] = d(0.02)
    p["C_h"] = d(2.5e5)
    p["R_ha"] = d(0.05)
    p["R_w"] = d(0.8)
    p["v_s"] = d(1.5e-3)
    # effect constants of the campaign (a separate stream: independent of the above)
    r2 = np.random.default_rng(np.random.SeedSequence([_u64(seed), 0x4A4], spawn_key=(2,)))
    p["phases"] = [float(x) for x in r2.uniform(0.0, 2.0 * math.pi, 12)]
    p["f_sine"] = float(r2.uniform(0.8, 1.4))
    p["f_pulse"] = float(r2.uniform(0.5, 0.8))
    p["f_out_mode"] = float(r2.uniform(8.0, 11.0))
    p["f_dyno_mode"] = float(r2.uniform(2.5, 3.5))
    return p


def _param_vector(p: dict, coupled: bool, temp_c: float) -> np.ndarray:
    P = np.zeros(NP)
    P[P_I] = p["I"]
    P[P_MRX] = p["mr_x"]
    P[P_MRY] = p["mr_y"]
    P[P_FV] = p["f_v"]
    P[P_FC] = p["F_c"]
    P[P_FS] = p["F_s0"]
    P[P_VS0] = p["v_s0"]
    P[P_SIG0] = p["sigma0"]
    P[P_SIG1] = p["sigma1"]
    P[P_VD] = p["v_d"]
    P[P_K1] = p["k1"]
    P[P_K2] = p["k2"]
    P[P_DK] = p["d_k"]
    P[P_DT] = p["D"]
    P[P_JMOT] = p["J_mot"]
    P[P_KT1], P[P_KT2], P[P_KT3] = p["k_t"]
    P[P_KTN] = p["k_t_nom"]
    P[P_MCF] = p["F_m"]
    P[P_MCV] = p["c_m"]
    P[P_KP] = p["K_p"]
    P[P_KI] = p["K_i"]
    P[P_TI1], P[P_TI2], P[P_TI3] = p["tau_i"]
    P[P_TMAX] = p["tau_max"]
    P[P_KPOS] = p["K_pos"]
    P[P_JD] = p["J_d"]
    P[P_CD] = p["c_d"]
    P[P_FD] = p["F_d"]
    P[P_WD] = p["w_d"]
    P[P_ZD] = p["zeta_d"]
    P[P_GERR] = p["eps_d"]
    P[P_KID] = p["K_id"]
    P[P_COUPLED] = 1.0 if coupled else 0.0
    P[P_CO] = p["C_o"]
    P[P_ROH] = p["R_oh"]
    P[P_CH] = p["C_h"]
    P[P_RHA] = p["R_ha"]
    P[P_TAMB] = temp_c
    P[P_RW] = p["R_w"]
    return P


def _is_number(x) -> bool:
    if isinstance(x, (bool, np.bool_)):
        return False
    return isinstance(x, (int, float, np.integer, np.floating))


def _parse_effects(effects) -> dict[str, tuple[str, float]]:
    if effects is None:
        return {}
    if not isinstance(effects, dict):
        raise ValueError("effects must be a dict of {name: {'form': ..., 'scale': ...}}, "
                         f"got {type(effects).__name__}")
    out = {}
    for name, spec in effects.items():
        if not isinstance(name, str) or name not in EFFECT_FORMS:
            raise ValueError(f"unknown effect {name!r}; known: {sorted(EFFECT_FORMS)}")
        if not isinstance(spec, dict):
            raise ValueError(f"effect {name!r}: its spec must be a dict with 'form' and 'scale'")
        for key in spec:
            if key not in ("form", "scale"):
                raise ValueError(f"effect {name!r}: unknown key {key!r} (allowed: 'form', 'scale')")
        if "scale" not in spec:
            raise ValueError(f"effect {name!r}: missing key 'scale'")
        form = spec.get("form", EFFECT_FORMS[name][0])
        if not isinstance(form, str) or form not in EFFECT_FORMS[name]:
            raise ValueError(f"effect {name!r}: unknown form {form!r}; known: {EFFECT_FORMS[name]}")
        s = spec["scale"]
        if not _is_number(s):
            raise ValueError(f"effect {name!r}: scale {s!r} is not a number")
        s = float(s)
        if not math.isfinite(s):
            raise ValueError(f"effect {name!r}: scale {s!r} is not finite")
        if s < 0.0:
            raise ValueError(f"effect {name!r}: scale {s!r} is negative")
        out[name] = (form, s)
    return out


def _effect_vector(eff: dict, p: dict) -> tuple[np.ndarray, dict]:
    """Compiled-model effect vector, plus the sensor-chain effects (applied after)."""
    E = np.zeros(NE)
    E[E_TREF] = T_REF_C
    E[E_HY_XM] = 1.2e-3
    E[E_PD_FR] = 1.0
    E[E_PD_W] = 0.06
    E[E_SR_W] = 1.0
    E[E_STR_VS] = p["v_s"]
    ph = p["phases"]
    post = {"offset_const": 0.0, "offset_rate": 0.0, "delay": 0.0, "lag": 0.0,
            "load_drift": 0.0, "enc_drift": 0.0}
    for name, (form, s0) in eff.items():
        if s0 == 0.0:
            continue
        s = min(s0, _SCALE_CLAMP[name])
        fi = EFFECT_FORMS[name].index(form) + 1.0
        if name == "stribeck":
            E[E_STR_F] = fi
            E[E_STR_DF] = 0.4 * p["F_c"] * s
        elif name == "temperature_friction":
            E[E_TMP_F] = fi
            E[E_TMP_S] = s
        elif name == "load_dependent_friction":
            E[E_LD_F] = fi
            if form == "coulomb":
                E[E_LD_MUC] = 0.015 * s
            else:
                E[E_LD_MUC] = 0.010 * s
                E[E_LD_MUV] = 0.8 * s
        elif name == "asymmetric_friction":
            if form in ("coulomb", "both"):
                E[E_AS_C] = min(0.12 * s, 0.8)
            if form in ("viscous", "both"):
                E[E_AS_V] = min(0.30 * s, 0.8)
        elif name == "gear_ripple":
            if form == "output_angle":
                E[E_RQ_A] = 600.0 * s
                E[E_RQ_Z] = 117.0
                E[E_RQ_P1], E[E_RQ_P2], E[E_RQ_P3] = ph[0], ph[1], ph[2]
            elif form == "motor_angle":
                E[E_RM_A] = 400.0 * s
                E[E_RM_Z] = 1100.0
                E[E_RM_P1], E[E_RM_P2] = ph[3], ph[4]
            else:
                E[E_KE_A] = 3.0e-4 * s
                E[E_KE_Z] = 58.0
                E[E_KE_P1], E[E_KE_P2] = ph[5], ph[6]
        elif name == "backlash":
            E[E_BL_F] = fi
            E[E_BL_B] = 6.0e-4 * s
        elif name == "hysteresis":
            E[E_HY_F] = fi
            E[E_HY_W] = min(0.15 * s, 0.8)
        elif name == "torque_offset":
            if form == "constant":
                post["offset_const"] = 600.0 * s
            else:
                post["offset_rate"] = 12.0 * s
        elif name == "time_delay":
            if form == "pure":
                post["delay"] = min(0.015 * s, 0.5)
            else:
                post["lag"] = min(0.02 * s, 0.5)
        elif name == "periodic_disturbance":
            E[E_PD_F] = fi
            if form == "sine":
                E[E_PD_A] = 500.0 * s
                E[E_PD_FR] = p["f_sine"]
                E[E_PD_P] = ph[7]
            else:
                E[E_PD_A] = 700.0 * s
                E[E_PD_FR] = p["f_pulse"]
                E[E_PD_P] = ph[8]
        elif name == "position_dependent_stiffness":
            E[E_PDS_F] = fi
            if form == "cosine":
                E[E_PDS_A] = min(0.2 * s, 0.7)
                E[E_PDS_P] = ph[9]
            else:
                E[E_PDS_A] = min(0.3 * s, 3.0)
        elif name == "sensor_drift":
            if form == "load_cell":
                post["load_drift"] = 10.0 * s
            else:
                post["enc_drift"] = 2.5e-5 * s
        elif name == "second_resonance":
            E[E_SR_F] = fi
            if form == "output_mode":
                E[E_SR_M] = 0.5 * s * p["I"]
                E[E_SR_W] = 2.0 * math.pi * p["f_out_mode"]
                E[E_SR_Z] = 0.02
            else:
                E[E_SR_M] = 1.0 * s * p["J_d"]
                E[E_SR_W] = 2.0 * math.pi * p["f_dyno_mode"]
                E[E_SR_Z] = 0.03
    return E, post


def _schedule(scheme: int, motor_speed_rpm, direction: int, periods: int):
    """Segments (t0, t1, kind, w0, w1, L0, L1) and their phase labels."""
    segs = []
    labels = []

    def add(dur, kind, w0, w1, l0, l1, label):
        t0 = segs[-1][1] if segs else 0.0
        segs.append((t0, t0 + dur, kind, w0, w1, l0, l1))
        labels.append(label)

    if scheme in (1, 2):
        w = direction * motor_speed_rpm * 2.0 * math.pi / 60.0 / REDUCTION
        lmax = direction * T_RATED
        add(1.0, 0, 0.0, 0.0, 0.0, 0.0, "rest")
        add(2.0, 1, 0.0, w, 0.0, 0.0, "accelerate")
        if scheme == 1:
            add(3.0, 0, w, w, 0.0, 0.0, "hold")
            add(24.0, 0, w, w, 0.0, lmax, "load")
            add(1.0, 0, w, w, lmax, lmax, "hold")
            add(24.0, 0, w, w, lmax, 0.0, "unload")
            add(1.0, 0, w, w, 0.0, 0.0, "hold")
        else:
            add(2.0, 0, w, w, 0.0, 0.0, "hold")
            step = direction * 10.0e3
            for k in range(12):
                add(0.15, 1, w, w, k * step, (k + 1) * step, "load")
                add(2.0, 0, w, w, (k + 1) * step, (k + 1) * step, "hold")
            for k in range(6):
                a = lmax - k * 2.0 * step
                b = lmax - (k + 1) * 2.0 * step
                add(0.15, 1, w, w, a, b, "unload")
                add(1.85, 0, w, w, b, b, "hold")
        add(2.0, 1, w, 0.0, 0.0, 0.0, "decelerate")
        add(1.0, 0, 0.0, 0.0, 0.0, 0.0, "rest")
    else:
        add(1.0, 0, 0.0, 0.0, 0.0, 0.0, "rest")
        add(_FOURIER_PERIOD * periods, 0, 0.0, 0.0, 0.0, 0.0, "excite")
        add(1.0, 0, 0.0, 0.0, 0.0, 0.0, "rest")
    return np.array(segs, dtype=np.float64), labels


def _fourier_coeffs(direction: int):
    a = np.array(_FOURIER_A, dtype=np.float64)
    b = np.array(_FOURIER_B, dtype=np.float64)
    ll = np.arange(1, 6, dtype=np.float64)
    a[-1] -= a.sum()
    b[-1] -= (ll * b).sum() / 5.0
    return direction * a, direction * b, 2.0 * math.pi / _FOURIER_PERIOD


def _check_args(scheme, motor_speed_rpm, direction, temp_joint_c, seed, sensors, periods, run):
    if isinstance(scheme, bool) or not isinstance(scheme, (int, np.integer)) or int(scheme) not in (1, 2, 3):
        raise ValueError(f"scheme must be 1, 2 or 3, got {scheme!r}")
    scheme = int(scheme)
    if scheme == 3:
        if motor_speed_rpm is not None:
            raise ValueError(f"scheme 3 takes motor_speed_rpm=None, got {motor_speed_rpm!r}")
    else:
        if not _is_number(motor_speed_rpm) or not math.isfinite(float(motor_speed_rpm)) \
                or not 1.0 <= float(motor_speed_rpm) <= 3000.0:
            raise ValueError(f"motor_speed_rpm must be a number in [1, 3000], got {motor_speed_rpm!r}")
    if isinstance(direction, bool) or not _is_number(direction) or direction not in (1, -1):
        raise ValueError(f"direction must be +1 or -1, got {direction!r}")
    if not _is_number(temp_joint_c) or not math.isfinite(float(temp_joint_c)) \
            or not -30.0 <= float(temp_joint_c) <= 90.0:
        raise ValueError(f"temp_joint_c must be a number in [-30, 90] degC, got {temp_joint_c!r}")
    for nm, val in (("seed", seed), ("run", run), ("periods", periods)):
        if isinstance(val, bool) or not isinstance(val, (int, np.integer)):
            raise ValueError(f"{nm} must be an integer, got {val!r}")
    if int(run) < 0:
        raise ValueError(f"run must be >= 0, got {run!r}")
    if not 1 <= int(periods) <= 20:
        raise ValueError(f"periods must be in [1, 20], got {periods!r}")
    if not isinstance(sensors, SensorSpec):
        raise ValueError(f"sensors must be a SensorSpec, got {type(sensors).__name__}")
    fs = sensors.sample_rate_hz
    if not _is_number(fs) or not math.isfinite(float(fs)) or not 10.0 <= float(fs) <= 1000.0:
        raise ValueError(f"sensors.sample_rate_hz must be in [10, 1000] Hz, got {fs!r}")
    for nm in ("encoder_res_deg", "torque_noise", "torque_lag_s", "load_noise",
               "current_noise", "speed_noise", "temp_noise"):
        val = getattr(sensors, nm)
        if not _is_number(val) or not math.isfinite(float(val)) or float(val) < 0.0:
            raise ValueError(f"sensors.{nm} must be a finite number >= 0, got {val!r}")
    if not float(sensors.encoder_res_deg) > 0.0:
        raise ValueError(f"sensors.encoder_res_deg must be > 0, got {sensors.encoder_res_deg!r}")
    if float(sensors.torque_lag_s) > 1.0:
        raise ValueError(f"sensors.torque_lag_s must be <= 1 s, got {sensors.torque_lag_s!r}")
    if sensors.torque_lag_kind not in ("pure", "first_order"):
        raise ValueError("sensors.torque_lag_kind must be 'pure' or 'first_order', "
                         f"got {sensors.torque_lag_kind!r}")
    return scheme


def simulate_run(scheme: int, motor_speed_rpm: float | None, direction: int, temp_joint_c: float,
                 effects: dict, *, seed: int, sensors: SensorSpec, periods: int = 3,
                 run: int = 0) -> RigRun:
    """Simulate one run of ``scheme`` on the campaign ``seed`` (noise of ``run``)."""
    scheme = _check_args(scheme, motor_speed_rpm, direction, temp_joint_c, seed, sensors, periods, run)
    eff = _parse_effects(effects)
    direction = int(direction)
    temp_c = float(temp_joint_c)
    fs = float(sensors.sample_rate_hz)
    p = nominal_parameters(int(seed))
    coupled = scheme in (1, 2)
    P = _param_vector(p, coupled, temp_c)
    E, post = _effect_vector(eff, p)
    seg, labels = _schedule(scheme, None if motor_speed_rpm is None else float(motor_speed_rpm),
                            direction, int(periods))
    fa, fb, wf = _fourier_coeffs(direction)
    tex0 = seg[0, 1] if scheme == 3 else 0.0
    tex1 = seg[1, 1] if scheme == 3 else 0.0
    duration = float(seg[-1, 1])
    n_sub = int(math.ceil((1.0 / fs) / DT_MAX - 1e-9))
    dt = 1.0 / (fs * n_sub)
    n_samples = int(math.floor(duration * fs + 1e-9)) + 1
    n_fine = (n_samples - 1) * n_sub + 1

    play = np.zeros(N_PLAY)
    u0 = _equilibrium(P, E, play)
    P[P_UOFF] = u0
    y = np.zeros(15)
    y[2] = u0
    fine_t = np.empty(n_fine)
    fine_l = np.empty(n_fine)
    fine_q = np.empty(n_fine)
    fine_ud = np.empty(n_fine)
    rec = np.zeros((n_samples, NREC))
    bad = _integrate(P, E, seg, fa, fb, wf, tex0, tex1, scheme, n_samples, n_sub, dt, y, play,
                     temp_c, fine_t, fine_l, fine_q, fine_ud, rec)
    active = {k: v for k, v in eff.items() if v[1] > 0.0}
    if bad >= 0 or not np.all(np.isfinite(rec)):
        raise RuntimeError(
            f"{RIG_NAME}: the integration went non-finite at t = {max(bad, 0) / fs:.3f} s "
            f"(scheme {scheme}, active effects and scales: "
            f"{ {k: {'form': f, 'scale': s} for k, (f, s) in active.items()} })")

    t = np.arange(n_samples) / fs
    rng = np.random.default_rng(np.random.SeedSequence([_u64(seed), _u64(run), 0x1A9]))
    nz_torque = rng.standard_normal(n_samples)
    nz_load = rng.standard_normal(n_samples)
    nz_i = rng.standard_normal((3, n_samples))
    nz_w = rng.standard_normal((3, n_samples))
    nz_temp = rng.standard_normal(n_samples)

    # ---- torque transducer chain
    tf = _lpf2(fine_t, TORQUE_FILTER_HZ, dt)
    lag_s = float(sensors.torque_lag_s)
    delay = post["delay"]
    if lag_s > 0.0:
        if sensors.torque_lag_kind == "first_order":
            tf = _lag1(tf, lag_s, dt)
        else:
            delay = delay + lag_s
    if post["lag"] > 0.0:
        tf = _lag1(tf, post["lag"], dt)
    torque_clean = _sample(tf, n_sub, n_samples, delay / dt)
    if post["offset_const"] != 0.0 or post["offset_rate"] != 0.0:
        torque_clean = torque_clean + post["offset_const"] + post["offset_rate"] * t
    torque_meas = TORQUE_ADC * np.round((torque_clean + float(sensors.torque_noise) * nz_torque) / TORQUE_ADC)

    # ---- load cell
    if coupled:
        lf = _lpf2(fine_l, LOAD_FILTER_HZ, dt)
        load_clean = _sample(lf, n_sub, n_samples, 0.0)
    else:
        load_clean = np.zeros(n_samples)
    if post["load_drift"] != 0.0:
        load_clean = load_clean + post["load_drift"] * t
    load_meas = LOAD_ADC * np.round((load_clean + float(sensors.load_noise) * nz_load) / LOAD_ADC)

    # ---- encoders and speeds
    q_true = rec[:, 0]
    step = math.radians(float(sensors.encoder_res_deg))
    q_read = q_true + post["enc_drift"] * t if post["enc_drift"] != 0.0 else q_true
    q_meas = step * np.floor(q_read / step + 0.5)
    qd_meas = _track_velocity(fine_q, dt, step, post["enc_drift"], n_sub, n_samples,
                              2.0 * math.pi * TRACK_HZ, True)
    # the velocity channel's noise is the encoder's quantisation seen through the loop: measured
    qd_smooth = _track_velocity(fine_q, dt, step, post["enc_drift"], n_sub, n_samples,
                                2.0 * math.pi * TRACK_HZ, False)
    qd_noise_sd = float(np.std(qd_meas - qd_smooth))
    u_true = rec[:, 2]
    u_meas = U_STEP * np.floor(u_true / U_STEP + 0.5)
    wf_fine = _lag1(fine_ud * REDUCTION, SPEED_FILTER_S, dt)
    w_clean = _sample(wf_fine, n_sub, n_samples, 0.0)
    w_meas = w_clean[None, :] + float(sensors.speed_noise) * nz_w
    ud_meas = w_meas.mean(axis=0) / REDUCTION
    i_true = rec[:, 6:9].T
    i_meas = CURRENT_STEP * np.round((i_true + float(sensors.current_noise) * nz_i) / CURRENT_STEP)
    # temperature: housing node through the sensor's lag (exact first order on the samples' grid)
    thou = rec[:, 15 + 11]
    tsens = np.empty(n_samples)
    a = 1.0 - math.exp(-1.0 / (fs * TEMP_LAG_S))
    s_ = thou[0]
    for k in range(n_samples):
        s_ += a * (thou[k] - s_)
        tsens[k] = s_
    temp_meas = TEMP_STEP * np.round((tsens + float(sensors.temp_noise) * nz_temp) / TEMP_STEP)

    # ---- phases
    lab_idx = np.searchsorted(seg[:, 1], t, side="right")
    lab_idx = np.minimum(lab_idx, len(labels) - 1)
    phase = np.array(labels, dtype=object)[lab_idx]

    samples = pd.DataFrame({
        "t": t,
        "q": q_meas,
        "qd": qd_meas,
        "u": u_meas,
        "ud": ud_meas,
        "torque": torque_meas,
        "torque_load": load_meas,
        "torque_cmd": rec[:, 15 + 8],
        "temp_joint": temp_meas,
        "phase": phase,
        "i_m1": i_meas[0], "i_m2": i_meas[1], "i_m3": i_meas[2],
        "w_m1": w_meas[0], "w_m2": w_meas[1], "w_m3": w_meas[2],
    })
    truth = pd.DataFrame({
        "t": t,
        "q": q_true,
        "qd": rec[:, 1],
        "qdd": rec[:, 15 + 4],
        "u": u_true,
        "ud": rec[:, 3],
        "twist": u_true - q_true,
        "twist_rate": rec[:, 3] - rec[:, 1],
        "twist_effective": rec[:, 15 + 9],
        "torque": torque_clean,
        "torque_load": load_clean,
        "torque_true": rec[:, 15 + 0],
        "torque_load_true": rec[:, 15 + 1],
        "friction_true": rec[:, 15 + 2],
        "gravity_true": rec[:, 15 + 3],
        "torque_unmodelled_true": rec[:, 15 + 6],
        "motor_torque_true": rec[:, 15 + 10],
        "bristle_z": rec[:, 4],
        "hysteresis_x": rec[:, 5],
        "i_m1": rec[:, 6], "i_m2": rec[:, 7], "i_m3": rec[:, 8],
        "temp_joint": rec[:, 15 + 7],
        "temp_housing": thou,
    })

    num = np.concatenate([samples.drop(columns="phase").to_numpy(dtype=float).ravel(),
                          truth.to_numpy(dtype=float).ravel()])
    if not np.all(np.isfinite(num)):
        raise RuntimeError(
            f"{RIG_NAME}: a non-finite value in the readings (scheme {scheme}, active effects and "
            f"scales: { {k: {'form': f, 'scale': s} for k, (f, s) in active.items()} })")

    lag_torque = math.sqrt(2.0) / (2.0 * math.pi * TORQUE_FILTER_HZ) + lag_s
    lag_load = math.sqrt(2.0) / (2.0 * math.pi * LOAD_FILTER_HZ)
    sens = {
        "q": {"resolution": step, "noise_sd": 0.0, "lag_s": 0.0, "unit": "rad"},
        "qd": {"resolution": 0.0, "noise_sd": qd_noise_sd, "lag_s": 0.0, "unit": "rad/s"},
        "u": {"resolution": U_STEP, "noise_sd": 0.0, "lag_s": 0.0, "unit": "rad"},
        "ud": {"resolution": 0.0, "noise_sd": float(sensors.speed_noise) / math.sqrt(3.0) / REDUCTION,
               "lag_s": SPEED_FILTER_S, "unit": "rad/s"},
        "torque": {"resolution": TORQUE_ADC, "noise_sd": float(sensors.torque_noise),
                   "lag_s": lag_torque, "unit": "N*m"},
        "torque_load": {"resolution": LOAD_ADC, "noise_sd": float(sensors.load_noise),
                        "lag_s": lag_load, "unit": "N*m"},
        "temp_joint": {"resolution": TEMP_STEP, "noise_sd": float(sensors.temp_noise),
                       "lag_s": TEMP_LAG_S, "unit": "degC"},
    }
    for j in (1, 2, 3):
        sens[f"i_m{j}"] = {"resolution": CURRENT_STEP, "noise_sd": float(sensors.current_noise),
                           "lag_s": 0.0, "unit": "A"}
        sens[f"w_m{j}"] = {"resolution": 0.0, "noise_sd": float(sensors.speed_noise),
                           "lag_s": SPEED_FILTER_S, "unit": "rad/s"}
    meta = {
        "scheme": scheme,
        "motor_speed_rpm": None if motor_speed_rpm is None else float(motor_speed_rpm),
        "direction": direction,
        "reduction": REDUCTION,
        "rig": RIG_NAME,
        "source": "emulator",
        "sample_rate_hz": fs,
        "duration_s": float(t[-1]),
        "temp_joint_c": temp_c,
        "seed": int(seed),
        "run": int(run),
        "periods": int(periods),
        "sensors": sens,
        "sensor_notes": {
            "q": "absolute output encoder, rounded to the step",
            "qd": "type-2 tracking loop (3 Hz, zero DC lag) on the quantised output encoder; "
                  "noise_sd = the quantisation's share, measured on this run",
            "torque": (f"Butterworth {TORQUE_FILTER_HZ:g} Hz (DC group delay in lag_s) + stated "
                       f"{sensors.torque_lag_kind} lag {lag_s:g} s, white noise, 16-bit ADC"),
            "torque_load": f"Butterworth {LOAD_FILTER_HZ:g} Hz, white noise, 16-bit ADC"
                           + ("" if coupled else "; dynamometer declutched (scheme 3)"),
            "temp_joint": "housing Pt100, first-order lag; the friction sees the lubricant (truth)",
        },
    }
    return RigRun(samples=samples, meta=meta, truth=truth)
