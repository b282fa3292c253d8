"""Validation rig Q: the CFETR CMOR joint-4 test platform, simulated from first principles.

DATA SHEET (SI units; temperatures in degC; transmission angles referred to the output)
=========================================================================================

Purpose
-------
An independent physics rig used to score the diagnosis tool BLIND. It shares no code with the
house emulator and differs on purpose from the textbook model (Eq. 4 + a linear or Bouc-Wen
spring): two inertias on the drive side of the torque transducer, a two-stage transmission that
hardens with load and whose damping grows with load, LuGre output friction with presliding,
lossy motors with a mesh efficiency, a closed speed loop, a dynamometer with its own torque loop
and errors, process noise, and a sensor chain with finite bandwidth, quantisation and a few
small, unstated imperfections.

Machine
-------
Three servo motors (k_t = 1.6 N m/A nominal, peak current 10 A each) drive the joint through a
precision reducer (N1 = 100, motor -> intermediate shaft) and a differential planetary stage
(N2 = 110, intermediate -> output): N = 11000. 3000 r/min at the motors is 0.02856 rad/s at the
output. A torque transducer between the joint's output flange and the output body measures the
transmitted torque T; a dynamometer (servo + reducer) loads the output with tau_L, measured by a
load cell on the loading shaft. The hydraulic cylinder holds a constant shear preload (about
20 kN; bending about 12 kN m) in every scheme.

Equations (output-referred: u = motor angle / N, th = intermediate shaft angle / N2, q = output)

  J_m u''  = T_m - T_1 - F_m                                motor rotors + first gears
  J_g th'' = T_1 - T_2 - c_g th'                            planetary input + carriers
  I   q''  = T_2 - tau_L - G(q) - F_o - tau_x               output body (Eq. 4 + the load)

  T_m   = N (k_t1 i_1 + k_t2 i_2 + k_t3 i_3) + n_m(t)       i_k: first-order current loops
  T_1   = k_1 (u - th) + c_1 (u' - th')                     precision reducer (linear)
  T_el  = k_2 s(q) D (1 + h min((D/D_r)^2, 9)),   D = dz(th - q),  D_r = T_r / k_2
  T_2   = T_el + c_2 (1 + kappa min(|T_el|/T_r, 3)) (th' - q') dz'(th - q) + T_h
  F_m   = c_mv u' + (F_mc + (1 - eta) |T_1|) tanh(u'/v_m)   motor-side losses, mesh efficiency
  G(q)  = g (mr_x sin q + mr_y cos q)
  F_o   = g_F z + sigma_1 exp(-(q'/v_d)^2) (q' - |q'| z) + f_v' q'       LuGre (normalised)
  z'    = (q' - |q'| z) / z_0                               bristle state, |z| <= 1
  g_F = f_c, f_v' = f_v, s(q) = 1, dz = identity, T_h = 0, tau_x = 0 in the nominal.

So the stage-2 law is NOT linear + viscous: the stiffness hardens by h (2-5 %) at rated twist
(cubic), and the stage damping grows with the transmitted load (kappa = 0.3-0.8), i.e. it is not
proportional to the twist rate alone. Steady sliding gives exactly Eq. 4's friction
f_c sgn(q') + f_v q' (LuGre's steady state), so T = tau_L + G(q) + f_c sgn(q') + f_v q' + I q''.
Twist (truth) Delta = u - q = (u - th) + (th - q) ~ T/k with k = (1/k_1 + 1/k_2)^-1 ~ 1.38e7
N m/rad (0.46 deg at 120 kN m), 1-3 % less at rated load from the hardening. At reversals the
output sticks while the drive winds the transmission through 2 f_c/k (a real, nominal effect).

Nominal values (paper Table 3 where it applies)
  I = 6685 kg m^2, mr_x = 20.78 kg m, mr_y = -34.54 kg m, f_v = 8683 N m s/rad, f_c = 2353 N m
  z_0 = 1e-4 rad (presliding), sigma_1 = 2 * 0.3 * sqrt(f_c/z_0 * I), v_d = 5e-4 rad/s
  k_1 = 4.0e7, k_2 = 2.1e7 N m/rad, damping ratios 0.08 (c_1 on J_g, c_2 on I), T_r = 120 kN m
  J_g = 6000 kg m^2, c_g = 5000 N m s/rad, J_m = 6.0e5 kg m^2 (3 rotors x ~1.65e-3 kg m^2 x N^2)
  F_mc = 7000 N m, c_mv = 1.2e5 N m s/rad, eta = 0.86-0.90, v_m = 2e-4 rad/s

Drive (S120-like): speed PI on the motor speed, bandwidth 25 rad/s, conditional integration at
the current limit; torque split equally by the NOMINAL k_t (the true k_t differ); current loops
3 ms; motor torque noise 500 N m (output-referred, 50 Hz band). Scheme 3 adds a motor-side
position loop (4 1/s) with velocity feed-forward on the Fourier trajectory.
Dynamometer: actuator torque tau_a following (1 + e_dyn) tau_cmd + PLC correction with a 20 ms
lag; the PLC integrates (0.8 1/s) the command minus the load-cell torque, both filtered (0.5 s);
tau_L = tau_a + reducer drag (~400 N m tanh(q'/1e-3) + 2e4 q') + ripple (~60 N m at 400 cycles
per output revolution) + torque noise (60 N m, 3 Hz band). Error well inside +-2 kN m.
Thermal: gearbox C = 1.5e5 J/K, R = 0.04 K/W to the ambient (~21 degC), heated by all losses
(the joint starts at temp_joint_c and drifts slowly); windings C = 1000 J/K, R = 0.6 K/W, copper
(1.5 R i^2, R = 1.2 ohm) and iron losses. Hydraulics: first-order pressure regulator (0.4 s).

Integrator
----------
Fixed-step classical RK4 compiled with numba (cache=True). Internal step h = 1/(fs m), m the
smallest integer with h <= 2 ms, so every sample instant is a step instant (10 Hz: 50 steps per
sample; 1 kHz: 1, h = 1 ms). Process noises are held over a step and scaled by sqrt(1/h), so
their spectra do not depend on h. Stiffest dynamics at SCALE_MAX: the stage springs on J_g with
stiffness and hysteresis effects, omega < ~300 rad/s (h omega < 0.6); the current loops
(h/3 ms < 0.7); the bristle rate |q'|/z_0, inside RK4's stability limit (2.8) for
|q'| < 0.14 rad/s, 5 x the top speed (the largest seen with every effect at SCALE_MAX is
0.1 rad/s). The bristle and hysteresis states are projected onto [-1, 1], their invariant set,
after every step, so no slip speed can make them diverge. Against h = 0.25 ms (noise off), h =
2 ms changes the truth torque by < 45 N m, and only with a sharp backlash at SCALE_MAX.

Schemes (direction d = +-1 is the sense of motion; the load command is always >= 0)
--------------------------------------------------------------------------------------
1  idle 0-3 s (start 1-2.5 s to the motor speed), load 3-27 s (tau_cmd 0 -> 120 kN m at
   5 kN m/s), hold 27-29 s, unload 29-53 s, idle 53-55 s (stop 53-54.5 s). 55 s.
2  idle 0-3 s, 12 x (load +10 kN m in 2 s, hold 2 s) to 120 kN m, unload 51-54 s
   (40 kN m/s), idle 54-56 s. 56 s.
3  idle 0-2 s, `periods` x 25 s of the fifth-order Fourier trajectory of Eq. 12 (coefficients
   optimised offline for the log condition number of Eq. 4's regressor; starts and ends at rest
   at q = 0; |q'| <= 0.95 x 0.02856 rad/s; q within -1.2..+2.8 deg, mirrored for d = -1),
   idle 1 s. tau_cmd = 0 (the dynamometer follows, with its drag).
Phases (column `phase`): idle, load, hold, unload, excite.

Sensors (what meta["sensors"] states: resolution, noise_sd, lag_s)
-----------------------------------------------------------------------
q        output encoder, step encoder_res_deg (default 0.01 deg), zeroed at the start
qd       encoder-interface velocity: backward difference of the fine encoder position, then a
         2nd-order Butterworth at f_v = min(velocity_filter_hz, fs/4) (default 10 Hz) + white
         noise velocity_noise (3e-5 rad/s); stated lag = its DC group delay sqrt(2)/(2 pi f_v)
qdd      derivative of that filter, first-order smoothed at f_v (an estimate; not stated)
u, ud    motor-1 encoder (2^16 counts/rev) / N; ud first-order filtered at min(50 Hz, fs/4)
torque   transducer: 2nd-order Butterworth torque_bandwidth_hz (100 Hz), pure lag torque_lag_s,
         white noise torque_noise (150 N m), 16-bit ADC over +-250 kN m (7.6 N m)
torque_load  load cell: 2nd-order Butterworth load_bandwidth_hz (30 Hz), noise load_noise
         (100 N m), same ADC
torque_cmd, i_m1..3 (noise current_noise 0.02 A, 1 mA steps), w_m1..3 (rad/s at the motors),
temp_m1..3, temp_joint (0.1 K steps), p_hyd [Pa], m_bend [N m], f_shear [N]

Campaign and run
----------------
`seed` draws the machine (relative sd, clipped at 2.5 sd): I 2 %, mr 5 %, f_v 4 %, f_c 3 %,
z_0 10 %, k_1, k_2 5 %, J_g 5 %, J_m 3 %, c_g, F_mc, c_mv 10 %, dynamometer drag and ripple
20 %; h, kappa, eta uniform; the ambient 21 +- 1.5 degC; effect phases. (seed, run) draws the
run's process and sensor noise in a fixed order independent of the effects, so runs that differ
only by an effect share their noise exactly; scale 0 reproduces the nominal bit for bit.

Unstated imperfections (params["unstated"], per campaign; never in meta)
--------------------------------------------------------------------------
- torque transducer gain error, sd 0.1 % (|.| <= 0.25 %); load-cell gain error, sd 0.08 %
- torque zero offset, sd 30 N m, and thermal zero drift, sd 3 N m/K x (T_joint - 25 degC)
- load-cell zero offset, sd 20 N m
- cross-talk of the hydraulic bending moment into the torque gauge, sd 0.2 % (~25 N m)
- output encoder: once-per-revolution eccentricity, |N(0, 1.2e-5 rad)| (~2.5 arcsec), and an
  interpolation error of 3-12 % of one count with a period of 32 counts
- motor torque constants k_t1..3, sd 1.5 % around the nominal the drive assumes

Effects: effects={name: {"form": f, "scale": s}}, 0 <= s <= SCALE_MAX = 10, s = 0 is nominal
------------------------------------------------------------------------------------------------
Sizes at s = 1 ("clearly visible, not huge"); all are linear in s for small s. Notation:
v = q', sg = tanh(v / 2e-5 rad/s), phi_T = exp(-(T_j - 15 degC)/20 K) with T_j the simulated
joint temperature, T_el the elastic stage-2 torque, T_r = 120 kN m.

stribeck: g_F += 0.5 f_c s shape(|v|/v_s), v_s = 1e-3 rad/s (3.5 % of the top speed)
  exponential exp(-x);  gaussian exp(-x^2);  lorentzian 1/(1+x^2);  sqrt exp(-x^0.5)
  (at 300 r/min, from s ~ 0.7 on, the drop from breakaway to sliding friction makes the
  output stick-slip on the compliant transmission: real physics, growing faster than linearly
  there; linear below)
load_dependent_friction
  coulomb: g_F += 0.015 s |T_el|;  coulomb_viscous: g_F += 0.010 s |T_el|, f_v' x (1 + 1.5 s
  |T_el|/T_r);  power_flow: g_F += s (0.0145 + 0.0075 tanh(T_el v / 20 W)) |T_el| (driving >
  back-driving);  quadratic: g_F += 0.9 f_c s (T_el/T_r)^2
temperature_friction
  viscous_mult: f_v' x (1 + s phi_T);  coulomb_add: g_F += 0.3 f_c s max(0, 1 - (T_j - 15)/75);
  both_mult: g_F x (1 + 0.2 s phi_T), f_v' x (1 + 0.6 s phi_T);
  warmup_drift: g_F += 0.25 f_c s phi_T (0.4 + 0.6 exp(-t / 30 s))  (drifts down along the run)
gear_ripple: tau_x += ..., on the output between transducer and load cell, A = 400 N m s
  output_mesh: A sin(96 q + p1);  motor_side: A sin(2 N2 th + p2) (2 per revolution of the
  planetary input shaft);  harmonics: A [sin(48q+p1) + 0.5 sin(96q+p2) + 0.25 sin(144q+p3)];
  load_modulated: 1.25 A (0.3 + 0.7 min(|T_el|/T_r, 2)) sin(96 q + p1)
torque_offset (torque reading only)
  constant: 400 s;  linear_drift: 8 s t [N m/s];  warmup: 500 s (1 - exp(-t/15 s));
  thermal: s (150 + 12 (T_j - 15))
time_delay (readings only; an encoder delay is left out: the harness measures torques)
  torque: pure lag 0.04 s x s;  load_cell: pure lag 0.04 s x s;
  torque_first_order: an extra first-order lag of 0.03 s x s on the torque reading
hysteresis (in stage 2: T_h; x normalised, x' = (D'/x_m) shape(x, D'))
  bouc_wen_n1: T_h = 2000 s x, x_m = 4e-4 rad, shape 1 - (0.75 sgn(D'x) + 0.25)|x|;
  bouc_wen_n2: the same with n = 2 and beta = gamma = 0.5;  dahl: shape (1 - x sgn D')^1.5;
  load_proportional: T_h = 0.02 s |T_el| x, shape 1 - x sgn D', x_m = 5e-5 rad
backlash (stage-2 dead zone, half-width b = 1.5e-4 rad x s; damping scaled by dz')
  sharp: D - b sgn D outside, 0 inside;  smooth: softplus transition of width 0.3 b;
  load_closing: sharp with b / (1 + |tau_a| / 30 kN m);  polynomial: sgn(D) D^2/(4b) for
  |D| < 2b, C1 at 2b
asymmetric_friction
  coulomb: g_F = f_c (1 + 0.2 s)^sg;  viscous: f_v' = f_v (1 + 0.5 s)^sg;
  both: (1 + 0.12 s)^sg and (1 + 0.3 s)^sg;  offset: tau_x += 0.2 f_c s (not gravity)
Out of the vocabulary:
periodic_disturbance
  output_torque: tau_x += 500 s [sin(2 pi 1.7 t + p) + 0.4 sin(2 pi 3.4 t + 2p)] (a pump);
  beat: tau_x += 600 s (0.5 + 0.5 sin(2 pi 0.07 t)) sin(2 pi 2.3 t + p);
  reading_pickup: torque reading += 250 s sin(2 pi 13.7 t + p)
position_stiffness: s(q) = exp(a s phi(q)) (positive at every scale)
  periodic: a = 0.08, phi = sin(2 (q - q_c));  graded: a = 0.08, phi = clip(q / 0.5 rad, -2, 2);
  localized: a = 0.15, phi = -exp(-((q - 0.03)/0.08)^2)
sensor_drift (readings only)
  load_cell_zero: 6 s t [N m/s];  torque_gain: gain x (1 + 0.006 s t / 60 s);
  random_walk: load-cell zero random walk of 60 s N m / sqrt(s)
second_resonance
  output_mode: an inertia J_a = 0.3 s I hung on the output by a spring, 4.5 Hz, zeta 0.02, in
  relative coordinates r'' = -w^2 r - 2 zeta w r' - q'', tau_x -= J_a (w^2 r + 2 zeta w r');
  loading_mode: a lightly damped mode of the loading train, m'' = w^2 (tau_a + n - m) -
  2 zeta w m' (2.4 Hz, zeta 0.04), tau_L += 0.2 s (m - tau_a - n)
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from datetime import UTC, datetime, timedelta
from functools import lru_cache

import numpy as np
import pandas as pd
from numba import njit
from scipy import signal

RIG_NAME = "rig_q"
REDUCTION = 11000.0
SEED_IS_CAMPAIGN = True
SCALE_MAX = 10.0

EFFECT_FORMS: dict[str, tuple[str, ...]] = {
    "stribeck": ("exponential", "gaussian", "lorentzian", "sqrt"),
    "load_dependent_friction": ("coulomb", "coulomb_viscous", "power_flow", "quadratic"),
    "temperature_friction": ("viscous_mult", "coulomb_add", "both_mult", "warmup_drift"),
    "gear_ripple": ("output_mesh", "motor_side", "harmonics", "load_modulated"),
    "torque_offset": ("constant", "linear_drift", "warmup", "thermal"),
    "time_delay": ("torque", "load_cell", "torque_first_order"),
    "hysteresis": ("bouc_wen_n1", "bouc_wen_n2", "dahl", "load_proportional"),
    "backlash": ("sharp", "smooth", "load_closing", "polynomial"),
    "asymmetric_friction": ("coulomb", "viscous", "both", "offset"),
    "periodic_disturbance": ("output_torque", "beat", "reading_pickup"),
    "position_stiffness": ("periodic", "graded", "localized"),
    "sensor_drift": ("load_cell_zero", "torque_gain", "random_walk"),
    "second_resonance": ("output_mode", "loading_mode"),
}
OUT_OF_VOCABULARY: tuple[str, ...] = (
    "periodic_disturbance", "position_stiffness", "sensor_drift", "second_resonance")
UNSTATED_VOCABULARY: dict[str, str] = {
    "torque_offset": "the torque transducer's zero (sd 30 N m) and its thermal drift (sd 3 N m/K "
                     "x (T_joint - 25 degC)), unstated",
    "time_delay": "the amplifiers' group delays, unstated: the load cell's 30 Hz Butterworth "
                  "(7.5 ms) against the torque transducer's 100 Hz one (2.25 ms), so the load "
                  "reading lags the torque reading by about 5 ms"}
"""Effects of the vocabulary that the rig carries at scale 0 without saying so in its metadata
(declared for the harness's score after rig Q's blind score; the rig's behaviour is
unchanged)."""

# --- fixed design figures --------------------------------------------------------------------
N1 = 100.0                       # precision reducer (motor -> intermediate shaft)
N2 = 110.0                       # differential planetary (intermediate -> output)
T_RATED = 120e3                  # N m
G0 = 9.80665                     # m/s^2
RPM_MAX = 3000.0
V_TOP = RPM_MAX * 2 * math.pi / 60 / REDUCTION   # output speed at 3000 r/min [rad/s]
H_MAX = 2e-3                     # largest internal step [s]
V_EPS = 2e-5                     # smoothing speed of direction-dependent laws [rad/s]
FOURIER_PERIOD = 25.0            # s
# Eq. 12 coefficients (a_l, b_l, l = 1..5) [rad/s], found offline by a random search minimising
# the log condition number of Eq. 4's column-normalised regressor, with sum(a) = 0 and
# sum(l b_l) = 0 (start and end at rest); rescaled below to 0.95 x the speed limit.
_FOURIER_A = np.array([-0.002128634035322728, -0.0009130145203260258, 0.000682245156771912,
                       -9.758419723825929e-05, 0.002456987596115103])
_FOURIER_B = np.array([0.0030058707928830503, -0.008335503851220514, 0.006947027161712714,
                       -0.006665518188541816, 0.0038972256357174195])
ADC_LSB = 500e3 / 65536          # 16-bit over +-250 kN m [N m]
MOTOR_COUNTS = 2 ** 16
TEMP_STEP = 0.1                  # K
CURRENT_STEP = 1e-3              # A
A_CYL = 8.0e-3                   # m^2, hydraulic cylinder
ARM_BEND = 0.6                   # m, bending lever
P_SET = 2.5e6                    # Pa
DYN_NOISE_SD = 60.0              # dynamometer torque noise [N m]
DYN_NOISE_HZ = 3.0               # its bandwidth (first order) [Hz]
MOTOR_NOISE_SD = 500.0           # motor torque (current loop) noise, output-referred [N m]
Z0_PRESLIDING = 1.0e-4           # LuGre presliding deflection f_c/sigma0 [rad]
ZETA_BRISTLE = 0.3               # LuGre micro-damping as a damping ratio on I
ZETA_STAGE = 0.08                # damping ratio of both transmission stages

# --- parameter vector of the compiled kernel -------------------------------------------------
(P_I, P_MRX, P_MRY, P_FV, P_FC, P_Z0, P_SIG1, P_VD,
 P_K1, P_C1, P_K2, P_C2, P_KAPPA, P_HARD, P_D2R, P_TR,
 P_JG, P_CG, P_JM, P_FMC, P_CMV, P_ETA, P_VM,
 P_KT1, P_KT2, P_KT3, P_KTN, P_NRED, P_IMAX, P_TAUI,
 P_KPW, P_KIW, P_KPOS, P_U0, P_WNOM,
 P_MODE, P_WF, P_TLEN, P_Q0, P_T0EX,
 P_TA, P_KID, P_EDYN, P_FDD, P_CDD, P_VDD, P_ADR, P_ZDR, P_PHDR, P_WCD, P_WCM,
 P_TAMB, P_CJ, P_RJ, P_CTH, P_RTH, P_RW, P_PFE, P_WTOP, P_PSET, P_TAUP,
 P_ST_F, P_ST_A, P_ST_VS, P_LD_F, P_LD_S, P_TF_F, P_TF_S,
 P_GR_F, P_GR_A, P_GR_PH1, P_GR_PH2, P_GR_PH3,
 P_HY_F, P_HY_A, P_HY_XM, P_BL_F, P_BL_B, P_AF_F, P_AF_S,
 P_PD_F, P_PD_A, P_PD_PH, P_PS_F, P_PS_S, P_PS_QC,
 P_SR_F, P_SR_J, P_SR_W, P_SR_Z, P_TLF, NP) = range(92)

(S_U, S_WU, S_TH, S_WG, S_Q, S_WQ, S_Z, S_XH, S_XIW, S_I1, S_I2, S_I3, S_TA, S_XID,
 S_ND, S_NM, S_RO, S_RDO, S_RG, S_RDG, S_TJ, S_TM1, S_TM2, S_TM3, S_PH, S_LF, S_CF,
 NS) = range(28)

(A_T1, A_T2, A_TEL, A_TL, A_FO, A_TM, A_QDD, A_TCMD, A_G, A_UDD, NA) = range(11)

(L_Q, L_WQ, L_U, L_WU, L_TH, L_T1, L_T2, L_TL, L_FO, L_TM, L_QDD, L_TCMD, L_G, L_I1, L_I2,
 L_I3, L_TJ, L_TM1, L_TM2, L_TM3, L_PH, L_XH, L_TA, L_UDD, NL) = range(25)


# --- the compiled kernel ---------------------------------------------------------------------

@njit(cache=True)
def _pwl(t, tt, vv):
    n = tt.shape[0]
    if t <= tt[0]:
        return vv[0]
    if t >= tt[n - 1]:
        return vv[n - 1]
    lo = 0
    hi = n - 1
    while hi - lo > 1:
        mid = (lo + hi) // 2
        if tt[mid] <= t:
            lo = mid
        else:
            hi = mid
    return vv[lo] + (t - tt[lo]) / (tt[hi] - tt[lo]) * (vv[hi] - vv[lo])


@njit(cache=True)
def _fourier(tau, P, fa, fb):
    if tau <= 0.0 or tau >= P[P_TLEN]:
        return 0.0, 0.0
    wf = P[P_WF]
    q = P[P_Q0]
    v = 0.0
    for k in range(fa.shape[0]):
        wl = wf * (k + 1)
        s = math.sin(wl * tau)
        c = math.cos(wl * tau)
        q += fa[k] / wl * s - fb[k] / wl * c
        v += fa[k] * c + fb[k] * s
    return q, v


@njit(cache=True)
def _softplus(x):
    if x > 30.0:
        return x
    if x < -30.0:
        return math.exp(x)
    return math.log1p(math.exp(x))


@njit(cache=True)
def _sigmoid(x):
    if x >= 0.0:
        return 1.0 / (1.0 + math.exp(-x))
    e = math.exp(x)
    return e / (1.0 + e)


@njit(cache=True)
def _deadzone(d, form, b):
    """Backlash dead zone of half-width b: (effective twist, local slope)."""
    if form == 0 or b <= 0.0:
        return d, 1.0
    if form == 1 or form == 3:
        if d > b:
            return d - b, 1.0
        if d < -b:
            return d + b, 1.0
        return 0.0, 0.0
    if form == 2:
        e = 0.3 * b
        a1 = (d - b) / e
        a2 = (-d - b) / e
        return e * (_softplus(a1) - _softplus(a2)), _sigmoid(a1) + _sigmoid(a2)
    ad = abs(d)
    if ad >= 2.0 * b:
        return d - math.copysign(b, d), 1.0
    return math.copysign(d * d / (4.0 * b), d), ad / (2.0 * b)


@njit(cache=True)
def _stiff_factor(q, P):
    f = int(P[P_PS_F])
    if f == 0:
        return 1.0
    s = P[P_PS_S]
    if f == 1:
        return math.exp(0.08 * s * math.sin(2.0 * (q - P[P_PS_QC])))
    if f == 2:
        return math.exp(0.08 * s * min(max(q / 0.5, -2.0), 2.0))
    x = (q - 0.03) / 0.08
    return math.exp(-0.15 * s * math.exp(-x * x))


@njit(cache=True)
def _sgn(x):
    if x > 0.0:
        return 1.0
    if x < 0.0:
        return -1.0
    return 0.0


@njit(cache=True)
def _deriv(t, y, P, tt, vv, ll, fa, fb, wd, wm, wp, dy, aux):
    u = y[S_U]
    wu = y[S_WU]
    th = y[S_TH]
    wg = y[S_WG]
    q = y[S_Q]
    v = y[S_WQ]
    z = y[S_Z]
    xh = y[S_XH]
    tj = y[S_TJ]
    # references: speed mode (schemes 1, 2) or position mode (scheme 3)
    if P[P_MODE] < 0.5:
        wref = P[P_WNOM] * _pwl(t, tt, vv)
        tcmd = _pwl(t, tt, ll)
    else:
        qr, vr = _fourier(t - P[P_T0EX], P, fa, fb)
        wref = vr + P[P_KPOS] * (qr + P[P_U0] - u)
        tcmd = 0.0
    # drive: speed PI, current limit with conditional integration, current loops
    e = wref - wu
    tref = P[P_KPW] * e + P[P_KIW] * y[S_XIW]
    iref = tref / (3.0 * P[P_NRED] * P[P_KTN])
    dxiw = e
    if iref > P[P_IMAX]:
        iref = P[P_IMAX]
        if e > 0.0:
            dxiw = 0.0
    elif iref < -P[P_IMAX]:
        iref = -P[P_IMAX]
        if e < 0.0:
            dxiw = 0.0
    i1 = y[S_I1]
    i2 = y[S_I2]
    i3 = y[S_I3]
    tm = P[P_NRED] * (P[P_KT1] * i1 + P[P_KT2] * i2 + P[P_KT3] * i3) + y[S_NM]
    # stage 1 and motor-side losses
    t1 = P[P_K1] * (u - th) + P[P_C1] * (wu - wg)
    fm = P[P_CMV] * wu + (P[P_FMC] + (1.0 - P[P_ETA]) * abs(t1)) * math.tanh(wu / P[P_VM])
    # stage 2: dead zone, hardening, load-dependent damping, hysteresis
    d2 = th - q
    dd2 = wg - v
    blf = int(P[P_BL_F])
    b = P[P_BL_B]
    if blf == 3:
        b = b / (1.0 + abs(y[S_TA]) / 30e3)
    dzv, slope = _deadzone(d2, blf, b)
    r = dzv / P[P_D2R]
    r2 = min(r * r, 9.0)
    tel = P[P_K2] * _stiff_factor(q, P) * dzv * (1.0 + P[P_HARD] * r2)
    at = abs(tel)
    tdamp = P[P_C2] * (1.0 + P[P_KAPPA] * min(at / P[P_TR], 3.0)) * dd2 * slope
    hyf = int(P[P_HY_F])
    th_h = 0.0
    dxh = 0.0
    if hyf > 0:
        if hyf == 1:
            shape = 1.0 - (0.75 * _sgn(dd2 * xh) + 0.25) * abs(xh)
        elif hyf == 2:
            shape = 1.0 - (0.5 * _sgn(dd2 * xh) + 0.5) * xh * xh
        elif hyf == 3:
            shape = max(1.0 - xh * _sgn(dd2), 0.0) ** 1.5
        else:
            shape = max(1.0 - xh * _sgn(dd2), 0.0)
        dxh = dd2 / P[P_HY_XM] * shape
        if hyf == 4:
            th_h = P[P_HY_A] * at * xh
        else:
            th_h = P[P_HY_A] * xh
    t2 = tel + tdamp + th_h
    # output friction: LuGre with effect-dependent level g and viscous slope
    fc = P[P_FC]
    fvv = P[P_FV]
    sg = math.tanh(v / V_EPS)
    aff = int(P[P_AF_F])
    afs = P[P_AF_S]
    g = fc
    tx_off = 0.0
    if aff == 1:
        g = fc * math.exp(sg * math.log1p(0.2 * afs))
    elif aff == 2:
        fvv = fvv * math.exp(sg * math.log1p(0.5 * afs))
    elif aff == 3:
        g = fc * math.exp(sg * math.log1p(0.12 * afs))
        fvv = fvv * math.exp(sg * math.log1p(0.3 * afs))
    elif aff == 4:
        tx_off = 0.2 * afs * fc
    stf = int(P[P_ST_F])
    if stf > 0:
        x = abs(v) / P[P_ST_VS]
        if stf == 1:
            sh = math.exp(-x)
        elif stf == 2:
            sh = math.exp(-x * x)
        elif stf == 3:
            sh = 1.0 / (1.0 + x * x)
        else:
            sh = math.exp(-math.sqrt(x))
        g += P[P_ST_A] * sh
    ldf = int(P[P_LD_F])
    lds = P[P_LD_S]
    if ldf == 1:
        g += lds * 0.015 * at
    elif ldf == 2:
        g += lds * 0.010 * at
        fvv = fvv * (1.0 + lds * 1.5 * min(at / P[P_TR], 3.0))
    elif ldf == 3:
        g += lds * (0.0145 + 0.0075 * math.tanh(tel * v / 20.0)) * at
    elif ldf == 4:
        rr = min(at / P[P_TR], 3.0)
        g += lds * 0.9 * fc * rr * rr
    tff = int(P[P_TF_F])
    if tff > 0:
        tfs = P[P_TF_S]
        phi = math.exp(-(tj - 15.0) / 20.0)
        if tff == 1:
            fvv = fvv * (1.0 + tfs * phi)
        elif tff == 2:
            g += tfs * 0.3 * fc * max(0.0, 1.0 - (tj - 15.0) / 75.0)
        elif tff == 3:
            g = g * (1.0 + 0.2 * tfs * phi)
            fvv = fvv * (1.0 + 0.6 * tfs * phi)
        else:
            g += tfs * 0.25 * fc * phi * (0.4 + 0.6 * math.exp(-t / 30.0))
    g = max(g, 0.05 * fc)
    vr_ = v / P[P_VD]
    slip = v - abs(v) * z
    dz = slip / P[P_Z0]
    fo = g * z + P[P_SIG1] * math.exp(-vr_ * vr_) * slip + fvv * v
    grav = G0 * (P[P_MRX] * math.sin(q) + P[P_MRY] * math.cos(q))
    # output-side effect torques
    tx = tx_off
    grf = int(P[P_GR_F])
    if grf == 1:
        tx += P[P_GR_A] * math.sin(96.0 * q + P[P_GR_PH1])
    elif grf == 2:
        tx += P[P_GR_A] * math.sin(2.0 * N2 * th + P[P_GR_PH2])
    elif grf == 3:
        tx += P[P_GR_A] * (math.sin(48.0 * q + P[P_GR_PH1]) + 0.5 * math.sin(96.0 * q + P[P_GR_PH2])
                           + 0.25 * math.sin(144.0 * q + P[P_GR_PH3]))
    elif grf == 4:
        tx += 1.25 * P[P_GR_A] * (0.3 + 0.7 * min(at / P[P_TR], 2.0)) * math.sin(96.0 * q + P[P_GR_PH1])
    pdf = int(P[P_PD_F])
    if pdf == 1:
        w1 = 2.0 * math.pi * 1.7 * t
        tx += P[P_PD_A] * (math.sin(w1 + P[P_PD_PH]) + 0.4 * math.sin(2.0 * w1 + 2.0 * P[P_PD_PH]))
    elif pdf == 2:
        tx += P[P_PD_A] * (0.5 + 0.5 * math.sin(2.0 * math.pi * 0.07 * t)) \
            * math.sin(2.0 * math.pi * 2.3 * t + P[P_PD_PH])
    # dynamometer
    tl = (y[S_TA] + P[P_FDD] * math.tanh(v / P[P_VDD]) + P[P_CDD] * v
          + P[P_ADR] * math.sin(P[P_ZDR] * q + P[P_PHDR]) + y[S_ND])
    # second resonance (relative coordinates)
    srf = int(P[P_SR_F])
    wa = P[P_SR_W]
    za = P[P_SR_Z]
    fao = 0.0
    if srf == 1:
        fao = P[P_SR_J] * (wa * wa * y[S_RO] + 2.0 * za * wa * y[S_RDO])
    elif srf == 2:
        tl += P[P_SR_J] * (y[S_RG] - y[S_TA] - y[S_ND])
    qdd = (t2 - tl - grav - fo - tx + fao) / P[P_I]
    thdd = (t1 - t2 - P[P_CG] * wg) / P[P_JG]
    udd = (tm - t1 - fm) / P[P_JM]

    dy[S_U] = wu
    dy[S_WU] = udd
    dy[S_TH] = wg
    dy[S_WG] = thdd
    dy[S_Q] = v
    dy[S_WQ] = qdd
    dy[S_Z] = dz
    dy[S_XH] = dxh
    dy[S_XIW] = dxiw
    dy[S_I1] = (iref - i1) / P[P_TAUI]
    dy[S_I2] = (iref - i2) / P[P_TAUI]
    dy[S_I3] = (iref - i3) / P[P_TAUI]
    dy[S_TA] = ((1.0 + P[P_EDYN]) * tcmd + y[S_XID] - y[S_TA]) / P[P_TA]
    dy[S_XID] = P[P_KID] * (y[S_CF] - y[S_LF])
    dy[S_LF] = (tl - y[S_LF]) / P[P_TLF]
    dy[S_CF] = (tcmd - y[S_CF]) / P[P_TLF]
    dy[S_ND] = P[P_WCD] * (wd - y[S_ND])
    dy[S_NM] = P[P_WCM] * (wm - y[S_NM])
    dy[S_RO] = y[S_RDO]
    dy[S_RDO] = -wa * wa * y[S_RO] - 2.0 * za * wa * y[S_RDO] - qdd
    dy[S_RG] = y[S_RDG]
    dy[S_RDG] = wa * wa * (y[S_TA] + y[S_ND] - y[S_RG]) - 2.0 * za * wa * y[S_RDG]
    ploss = abs(fm * wu) + abs(fo * v) + P[P_CG] * wg * wg + abs(tdamp * dd2)
    dy[S_TJ] = (ploss - (tj - P[P_TAMB]) / P[P_RJ]) / P[P_CJ]
    pfe = P[P_PFE] * abs(wu) / P[P_WTOP]
    dy[S_TM1] = (1.5 * P[P_RW] * i1 * i1 + pfe - (y[S_TM1] - P[P_TAMB]) / P[P_RTH]) / P[P_CTH]
    dy[S_TM2] = (1.5 * P[P_RW] * i2 * i2 + pfe - (y[S_TM2] - P[P_TAMB]) / P[P_RTH]) / P[P_CTH]
    dy[S_TM3] = (1.5 * P[P_RW] * i3 * i3 + pfe - (y[S_TM3] - P[P_TAMB]) / P[P_RTH]) / P[P_CTH]
    dy[S_PH] = (P[P_PSET] + wp - y[S_PH]) / P[P_TAUP]

    aux[A_T1] = t1
    aux[A_T2] = t2
    aux[A_TEL] = tel
    aux[A_TL] = tl
    aux[A_FO] = fo
    aux[A_TM] = tm
    aux[A_QDD] = qdd
    aux[A_TCMD] = tcmd
    aux[A_G] = grav
    aux[A_UDD] = udd


@njit(cache=True)
def _integrate(y0, P, tt, vv, ll, fa, fb, n_int, h, wd, wm, wp):
    """Classical RK4 with a fixed step h; logs states and forces at every step instant."""
    ns = y0.shape[0]
    out = np.empty((n_int + 1, NL))
    y = y0.copy()
    k1 = np.empty(ns)
    k2 = np.empty(ns)
    k3 = np.empty(ns)
    k4 = np.empty(ns)
    yt = np.empty(ns)
    aux = np.empty(NA)
    dummy = np.empty(NA)
    for i in range(n_int + 1):
        t = i * h
        _deriv(t, y, P, tt, vv, ll, fa, fb, wd[i], wm[i], wp[i], k1, aux)
        out[i, L_Q] = y[S_Q]
        out[i, L_WQ] = y[S_WQ]
        out[i, L_U] = y[S_U]
        out[i, L_WU] = y[S_WU]
        out[i, L_TH] = y[S_TH]
        out[i, L_T1] = aux[A_T1]
        out[i, L_T2] = aux[A_T2]
        out[i, L_TL] = aux[A_TL]
        out[i, L_FO] = aux[A_FO]
        out[i, L_TM] = aux[A_TM]
        out[i, L_QDD] = aux[A_QDD]
        out[i, L_TCMD] = aux[A_TCMD]
        out[i, L_G] = aux[A_G]
        out[i, L_I1] = y[S_I1]
        out[i, L_I2] = y[S_I2]
        out[i, L_I3] = y[S_I3]
        out[i, L_TJ] = y[S_TJ]
        out[i, L_TM1] = y[S_TM1]
        out[i, L_TM2] = y[S_TM2]
        out[i, L_TM3] = y[S_TM3]
        out[i, L_PH] = y[S_PH]
        out[i, L_XH] = y[S_XH]
        out[i, L_TA] = y[S_TA]
        out[i, L_UDD] = aux[A_UDD]
        if i == n_int:
            break
        if not np.isfinite(k1[S_WQ]):
            out[i + 1:, :] = np.nan
            break
        for s in range(ns):
            yt[s] = y[s] + 0.5 * h * k1[s]
        _deriv(t + 0.5 * h, yt, P, tt, vv, ll, fa, fb, wd[i], wm[i], wp[i], k2, dummy)
        for s in range(ns):
            yt[s] = y[s] + 0.5 * h * k2[s]
        _deriv(t + 0.5 * h, yt, P, tt, vv, ll, fa, fb, wd[i], wm[i], wp[i], k3, dummy)
        for s in range(ns):
            yt[s] = y[s] + h * k3[s]
        _deriv(t + h, yt, P, tt, vv, ll, fa, fb, wd[i], wm[i], wp[i], k4, dummy)
        for s in range(ns):
            y[s] += h / 6.0 * (k1[s] + 2.0 * k2[s] + 2.0 * k3[s] + k4[s])
        # the bristle and hysteresis states live in [-1, 1] (invariant sets of their laws):
        # project back so that no step can leave them, whatever the slip speed
        y[S_Z] = min(max(y[S_Z], -1.0), 1.0)
        y[S_XH] = min(max(y[S_XH], -1.0), 1.0)
    return out


# --- public interface ------------------------------------------------------------------------

@dataclass(frozen=True)
class SensorSpec:
    """The bench's sensor chain (what a data sheet states). Units SI."""
    sample_rate_hz: float = 100.0       # acquisition rate of every channel [Hz]
    encoder_res_deg: float = 0.01       # output encoder step [deg]
    torque_noise: float = 150.0         # torque transducer noise sd [N m]
    torque_lag_s: float = 0.0           # pure extra lag of the torque reading [s]
    load_noise: float = 100.0           # load cell noise sd [N m]
    torque_bandwidth_hz: float = 100.0  # transducer amplifier, 2nd-order Butterworth [Hz]
    load_bandwidth_hz: float = 30.0     # load-cell amplifier, 2nd-order Butterworth [Hz]
    velocity_filter_hz: float = 10.0    # encoder-interface velocity filter [Hz]
    velocity_noise: float = 3e-5        # qd noise sd [rad/s]
    current_noise: float = 0.02         # motor current noise sd [A]


_DEFAULT_SENSORS = SensorSpec()


@dataclass
class RigRun:
    samples: pd.DataFrame
    meta: dict
    truth: pd.DataFrame
    params: dict


def _clip_normal(rng: np.random.Generator, sd: float, lim: float = 2.5) -> float:
    return float(sd * np.clip(rng.standard_normal(), -lim, lim))


@lru_cache(maxsize=32)
def _campaign_frozen(seed: int) -> tuple:
    rng = np.random.default_rng([seed, 0x5157])

    def rel(nominal: float, sd: float) -> float:
        return float(nominal * (1.0 + _clip_normal(rng, sd)))

    c: dict = {}
    c["I"] = rel(6685.166, 0.02)
    c["mr_x"] = rel(20.779, 0.05)
    c["mr_y"] = rel(-34.543, 0.05)
    c["f_v"] = rel(8683.272, 0.04)
    c["f_c"] = rel(2352.660, 0.03)
    c["z0_presliding"] = rel(Z0_PRESLIDING, 0.10)
    c["k1"] = rel(4.0e7, 0.05)
    c["k2"] = rel(2.1e7, 0.05)
    c["hardening"] = float(rng.uniform(0.02, 0.05))
    c["kappa"] = float(rng.uniform(0.3, 0.8))
    c["J_g"] = rel(6000.0, 0.05)
    c["c_g"] = rel(5000.0, 0.10)
    c["J_m"] = rel(6.0e5, 0.03)
    c["F_mc"] = rel(7000.0, 0.10)
    c["c_mv"] = rel(1.2e5, 0.10)
    c["eta"] = float(rng.uniform(0.86, 0.90))
    c["dyn_gain_error"] = _clip_normal(rng, 0.004)
    c["dyn_drag_coulomb"] = rel(400.0, 0.20)
    c["dyn_drag_viscous"] = rel(2.0e4, 0.20)
    c["dyn_ripple"] = rel(60.0, 0.20)
    c["dyn_ripple_phase"] = float(rng.uniform(0, 2 * math.pi))
    c["T_ambient"] = 21.0 + _clip_normal(rng, 1.5)
    c["ripple_phases"] = tuple(float(x) for x in rng.uniform(0, 2 * math.pi, 3))
    c["disturbance_phase"] = float(rng.uniform(0, 2 * math.pi))
    c["stiffness_phase_q"] = float(rng.uniform(0, math.pi))
    c["c1"] = 2 * ZETA_STAGE * math.sqrt(c["k1"] * c["J_g"])
    c["c2"] = 2 * ZETA_STAGE * math.sqrt(c["k2"] * c["I"])
    c["sigma0"] = c["f_c"] / c["z0_presliding"]
    c["sigma1"] = 2 * ZETA_BRISTLE * math.sqrt(c["sigma0"] * c["I"])
    un: dict = {}
    un["torque_gain_error"] = float(np.clip(rng.normal(0, 0.001), -0.0025, 0.0025))
    un["load_cell_gain_error"] = float(np.clip(rng.normal(0, 0.0008), -0.002, 0.002))
    un["torque_zero_nm"] = _clip_normal(rng, 30.0)
    un["torque_zero_tempco_nm_per_k"] = _clip_normal(rng, 3.0)
    un["load_cell_zero_nm"] = _clip_normal(rng, 20.0)
    un["bending_crosstalk"] = _clip_normal(rng, 0.002)
    un["encoder_eccentricity_rad"] = abs(_clip_normal(rng, 1.2e-5))
    un["encoder_eccentricity_phase"] = float(rng.uniform(0, 2 * math.pi))
    un["encoder_interpolation_frac"] = float(rng.uniform(0.03, 0.12))
    un["encoder_interpolation_phase"] = float(rng.uniform(0, 2 * math.pi))
    un["kt"] = tuple(1.6 * (1.0 + _clip_normal(rng, 0.015)) for _ in range(3))
    c["unstated"] = tuple(un.items())
    return tuple(c.items())


def _campaign(seed: int) -> dict:
    c = dict(_campaign_frozen(seed))
    c["unstated"] = dict(c["unstated"])
    return c


def _check_number(name: str, value, lo: float | None = None, hi: float | None = None,
                  lo_open: bool = False) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise ValueError(f"{name} must be a number, got {value!r}")  # noqa: TRY004 (the contract)
    x = float(value)
    if not math.isfinite(x):
        raise ValueError(f"{name} must be finite, got {value!r}")
    if lo is not None and (x <= lo if lo_open else x < lo):
        raise ValueError(f"{name} must be {'>' if lo_open else '>='} {lo}, got {value!r}")
    if hi is not None and x > hi:
        raise ValueError(f"{name} must be <= {hi}, got {value!r}")
    return x


def _check_int(name: str, value, lo: int | None = None, hi: int | None = None) -> int:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
        raise ValueError(f"{name} must be an integer, got {value!r}")  # noqa: TRY004
    if lo is not None and value < lo:
        raise ValueError(f"{name} must be >= {lo}, got {value!r}")
    if hi is not None and value > hi:
        raise ValueError(f"{name} must be <= {hi}, got {value!r}")
    return int(value)


def _check_sensors(s: SensorSpec) -> None:
    if not isinstance(s, SensorSpec):
        raise ValueError(  # noqa: TRY004 (the harness's contract: bad arguments raise ValueError)
            f"sensors must be a {__name__}.SensorSpec, got {type(s).__name__}")
    _check_number("sensors.sample_rate_hz", s.sample_rate_hz, 1.0, 10000.0)
    _check_number("sensors.encoder_res_deg", s.encoder_res_deg, 0.0, 1.0, lo_open=True)
    _check_number("sensors.torque_noise", s.torque_noise, 0.0, 1e5)
    _check_number("sensors.torque_lag_s", s.torque_lag_s, 0.0, 5.0)
    _check_number("sensors.load_noise", s.load_noise, 0.0, 1e5)
    _check_number("sensors.torque_bandwidth_hz", s.torque_bandwidth_hz, 0.0, 1e4, lo_open=True)
    _check_number("sensors.load_bandwidth_hz", s.load_bandwidth_hz, 0.0, 1e4, lo_open=True)
    _check_number("sensors.velocity_filter_hz", s.velocity_filter_hz, 0.0, 1e3, lo_open=True)
    _check_number("sensors.velocity_noise", s.velocity_noise, 0.0, 1.0)
    _check_number("sensors.current_noise", s.current_noise, 0.0, 10.0)


def _check_effects(effects) -> dict[str, tuple[str, float]]:
    if effects is None:
        return {}
    if not isinstance(effects, dict):
        raise ValueError(  # noqa: TRY004
            f"effects must be a dict {{name: {{'form', 'scale'}}}}, got {effects!r}")
    out: dict[str, tuple[str, float]] = {}
    for name, spec in effects.items():
        if name not in EFFECT_FORMS:
            raise ValueError(f"effects: unknown effect {name!r}; known: {sorted(EFFECT_FORMS)}")
        if not isinstance(spec, dict):
            raise ValueError(  # noqa: TRY004
                f"effects[{name!r}] must be a dict with 'form' and 'scale', got {spec!r}")
        extra = set(spec) - {"form", "scale"}
        if extra:
            raise ValueError(f"effects[{name!r}] has unknown keys {sorted(extra)}; "
                             "expected 'form' and 'scale'")
        if "form" not in spec or "scale" not in spec:
            raise ValueError(f"effects[{name!r}] needs both 'form' and 'scale', got {spec!r}")
        form = spec["form"]
        if form not in EFFECT_FORMS[name]:
            raise ValueError(f"effects[{name!r}]['form']: unknown form {form!r}; "
                             f"known: {list(EFFECT_FORMS[name])}")
        scale = _check_number(f"effects[{name!r}]['scale']", spec["scale"], 0.0, SCALE_MAX)
        out[name] = (form, scale)
    return out


def _schedule(scheme: int, direction: int, periods: int):
    """Piecewise-linear speed profile (normalised) and load command; phase segments."""
    if scheme == 1:
        tt = [0.0, 1.0, 2.5, 3.0, 27.0, 29.0, 53.0, 54.5, 55.0]
        vv = [0.0, 0.0, 1.0, 1.0, 1.0, 1.0, 1.0, 0.0, 0.0]
        ll = [0.0, 0.0, 0.0, 0.0, T_RATED, T_RATED, 0.0, 0.0, 0.0]
        phases = [(3.0, "idle"), (27.0, "load"), (29.0, "hold"), (53.0, "unload"), (55.0, "idle")]
        t_end = 55.0
    elif scheme == 2:
        tt = [0.0, 1.0, 2.5, 3.0]
        vv = [0.0, 0.0, 1.0, 1.0]
        ll = [0.0, 0.0, 0.0, 0.0]
        phases = [(3.0, "idle")]
        t = 3.0
        for k in range(1, 13):
            tt += [t + 2.0, t + 4.0]
            vv += [1.0, 1.0]
            ll += [10e3 * k, 10e3 * k]
            phases += [(t + 2.0, "load"), (t + 4.0, "hold")]
            t += 4.0
        tt += [54.0, 55.5, 56.0]
        vv += [1.0, 0.0, 0.0]
        ll += [0.0, 0.0, 0.0]
        phases += [(54.0, "unload"), (56.0, "idle")]
        t_end = 56.0
    else:
        t_len = periods * FOURIER_PERIOD
        t_end = 2.0 + t_len + 1.0
        tt = [0.0, t_end]
        vv = [0.0, 0.0]
        ll = [0.0, 0.0]
        phases = [(2.0, "idle"), (2.0 + t_len, "excite"), (t_end, "idle")]
    return (np.array(tt, float), np.array(vv, float), np.array(ll, float), phases, t_end)


def _fourier_coefficients(direction: int):
    a = _FOURIER_A.copy()
    b = _FOURIER_B.copy()
    wf = 2 * math.pi / FOURIER_PERIOD
    t = np.linspace(0, FOURIER_PERIOD, 5001)
    ell = np.arange(1, 6)[:, None]
    v = (a[:, None] * np.cos(wf * ell * t) + b[:, None] * np.sin(wf * ell * t)).sum(0)
    k = 0.95 * V_TOP / np.abs(v).max() * direction
    a *= k
    b *= k
    q0 = float((b / (wf * np.arange(1, 6))).sum())
    return a, b, wf, q0


def _effect_settings(eff: dict[str, tuple[str, float]], c: dict) -> dict:
    """Kernel parameters of the physical effects and settings of the reading effects."""
    s: dict = {"P": {}, "read": {}}
    P = s["P"]

    def code(name: str) -> int:
        return EFFECT_FORMS[name].index(eff[name][0]) + 1

    def scale(name: str) -> float:
        return eff[name][1]

    active = {n for n, (_, sc) in eff.items() if sc > 0.0}
    if "stribeck" in active:
        P[P_ST_F] = code("stribeck")
        P[P_ST_A] = 0.5 * c["f_c"] * scale("stribeck")
        P[P_ST_VS] = 1.0e-3
    if "load_dependent_friction" in active:
        P[P_LD_F] = code("load_dependent_friction")
        P[P_LD_S] = scale("load_dependent_friction")
    if "temperature_friction" in active:
        P[P_TF_F] = code("temperature_friction")
        P[P_TF_S] = scale("temperature_friction")
    if "gear_ripple" in active:
        P[P_GR_F] = code("gear_ripple")
        P[P_GR_A] = 400.0 * scale("gear_ripple")
    if "hysteresis" in active:
        f = code("hysteresis")
        P[P_HY_F] = f
        if f == 4:
            P[P_HY_A] = 0.02 * scale("hysteresis")
            P[P_HY_XM] = 5e-5
        else:
            P[P_HY_A] = 2000.0 * scale("hysteresis")
            P[P_HY_XM] = 4e-4
    if "backlash" in active:
        P[P_BL_F] = code("backlash")
        P[P_BL_B] = 1.5e-4 * scale("backlash")
    if "asymmetric_friction" in active:
        P[P_AF_F] = code("asymmetric_friction")
        P[P_AF_S] = scale("asymmetric_friction")
    if "periodic_disturbance" in active:
        form = eff["periodic_disturbance"][0]
        if form == "reading_pickup":
            s["read"]["pickup"] = 250.0 * scale("periodic_disturbance")
        else:
            P[P_PD_F] = code("periodic_disturbance")
            P[P_PD_A] = (500.0 if form == "output_torque" else 600.0) * scale("periodic_disturbance")
    if "position_stiffness" in active:
        P[P_PS_F] = code("position_stiffness")
        P[P_PS_S] = scale("position_stiffness")
    if "second_resonance" in active:
        f = code("second_resonance")
        P[P_SR_F] = f
        if f == 1:
            P[P_SR_J] = 0.3 * scale("second_resonance") * c["I"]
            P[P_SR_W] = 2 * math.pi * 4.5
            P[P_SR_Z] = 0.02
        else:
            P[P_SR_J] = 0.2 * scale("second_resonance")
            P[P_SR_W] = 2 * math.pi * 2.4
            P[P_SR_Z] = 0.04
    for name in ("torque_offset", "time_delay", "sensor_drift"):
        if name in active:
            s["read"][name] = eff[name]
    return s


def _butter_lp(x: np.ndarray, fc: float, h: float, order: int = 2) -> np.ndarray:
    fc = min(fc, 0.45 / h)
    b, a = signal.butter(order, fc, fs=1.0 / h)
    zi = signal.lfilter_zi(b, a) * x[0]
    return signal.lfilter(b, a, x, zi=zi)[0]


def _first_order(x: np.ndarray, tau: float, h: float) -> np.ndarray:
    """Exact discretisation (ZOH) of a first-order lag of time constant tau."""
    if tau <= 0:
        return x.copy()
    a = math.exp(-h / tau)
    return signal.lfilter([1 - a], [1, -a], x, zi=[a * x[0]])[0]


def simulate_run(scheme: int, motor_speed_rpm: float | None, direction: int,
                 temp_joint_c: float, effects: dict[str, dict] | None = None, *,
                 sensors: SensorSpec = _DEFAULT_SENSORS, periods: int = 3, seed: int,
                 run: int) -> RigRun:
    """Simulate one run of a campaign: `seed` draws the campaign's machine, (seed, run) the run's
    noise. See the module docstring (the rig's data sheet)."""
    # ---- arguments
    if isinstance(scheme, bool) or not isinstance(scheme, (int, np.integer)) or scheme not in (1, 2, 3):
        raise ValueError(f"scheme must be 1, 2 or 3, got {scheme!r}")
    scheme = int(scheme)
    if scheme == 3:
        if motor_speed_rpm is not None:
            raise ValueError(f"motor_speed_rpm must be None for scheme 3, got {motor_speed_rpm!r}")
        rpm = None
    else:
        if motor_speed_rpm is None:
            raise ValueError(f"motor_speed_rpm is required for scheme {scheme} (0 < rpm <= 3000)")
        rpm = _check_number("motor_speed_rpm", motor_speed_rpm, 0.0, RPM_MAX, lo_open=True)
    if isinstance(direction, bool) or not isinstance(direction, (int, float, np.integer, np.floating)) \
            or direction not in (1, -1):
        raise ValueError(f"direction must be +1 or -1, got {direction!r}")
    direction = int(direction)
    tj0 = _check_number("temp_joint_c", temp_joint_c, -20.0, 100.0)
    eff = _check_effects(effects)
    _check_sensors(sensors)
    periods = _check_int("periods", periods, 1, 40)
    seed = _check_int("seed", seed, 0)
    run = _check_int("run", run, 0)

    c = _campaign(seed)
    un = c["unstated"]
    fx = _effect_settings(eff, c)
    rng = np.random.default_rng([seed, run, 0x51])

    # ---- time grid: every sample instant is a step instant
    fs = float(sensors.sample_rate_hz)
    tt, vv, ll, phases, t_end = _schedule(scheme, direction, periods)
    n = math.floor(t_end * fs + 1e-9) + 1
    m = max(1, math.ceil(1.0 / (fs * H_MAX) - 1e-9))
    h = 1.0 / (fs * m)
    n_int = (n - 1) * m
    t_s = np.arange(n) / fs
    t_i = np.arange(n_int + 1) * h

    # ---- parameter vector
    P = np.zeros(NP)
    P[P_I] = c["I"]
    P[P_MRX] = c["mr_x"]
    P[P_MRY] = c["mr_y"]
    P[P_FV] = c["f_v"]
    P[P_FC] = c["f_c"]
    P[P_Z0] = c["z0_presliding"]
    P[P_SIG1] = c["sigma1"]
    P[P_VD] = 5e-4
    P[P_K1] = c["k1"]
    P[P_C1] = c["c1"]
    P[P_K2] = c["k2"]
    P[P_C2] = c["c2"]
    P[P_KAPPA] = c["kappa"]
    P[P_HARD] = c["hardening"]
    P[P_TR] = T_RATED
    P[P_D2R] = T_RATED / c["k2"]
    P[P_JG] = c["J_g"]
    P[P_CG] = c["c_g"]
    P[P_JM] = c["J_m"]
    P[P_FMC] = c["F_mc"]
    P[P_CMV] = c["c_mv"]
    P[P_ETA] = c["eta"]
    P[P_VM] = 2e-4
    P[P_KT1], P[P_KT2], P[P_KT3] = un["kt"]
    P[P_KTN] = 1.6
    P[P_NRED] = REDUCTION
    P[P_IMAX] = 10.0
    P[P_TAUI] = 3e-3
    jtot = c["J_m"] + c["J_g"] + c["I"]
    P[P_KPW] = jtot * 25.0
    P[P_KIW] = jtot * 25.0 * 25.0 / 5.0
    P[P_KPOS] = 4.0
    P[P_WNOM] = 0.0 if rpm is None else direction * rpm * 2 * math.pi / 60 / REDUCTION
    fa, fb = np.zeros(5), np.zeros(5)
    if scheme == 3:
        fa, fb, wf, q0 = _fourier_coefficients(direction)
        P[P_MODE] = 1.0
        P[P_WF] = wf
        P[P_TLEN] = periods * FOURIER_PERIOD
        P[P_Q0] = q0
        P[P_T0EX] = 2.0
    P[P_TA] = 0.02
    P[P_KID] = 0.8
    P[P_TLF] = 0.5
    P[P_EDYN] = c["dyn_gain_error"]
    P[P_FDD] = c["dyn_drag_coulomb"]
    P[P_CDD] = c["dyn_drag_viscous"]
    P[P_VDD] = 1e-3
    P[P_ADR] = c["dyn_ripple"]
    P[P_ZDR] = 400.0
    P[P_PHDR] = c["dyn_ripple_phase"]
    P[P_WCD] = 2 * math.pi * DYN_NOISE_HZ
    P[P_WCM] = 2 * math.pi * 50.0
    P[P_TAMB] = c["T_ambient"]
    P[P_CJ] = 1.5e5
    P[P_RJ] = 0.04
    P[P_CTH] = 1000.0
    P[P_RTH] = 0.6
    P[P_RW] = 1.2
    P[P_PFE] = 12.0
    P[P_WTOP] = V_TOP
    P[P_PSET] = P_SET
    P[P_TAUP] = 0.4
    P[P_GR_PH1], P[P_GR_PH2], P[P_GR_PH3] = c["ripple_phases"]
    P[P_PD_PH] = c["disturbance_phase"]
    P[P_PS_QC] = c["stiffness_phase_q"]
    P[P_SR_W] = 10.0
    P[P_SR_Z] = 0.5
    for k, val in fx["P"].items():
        P[k] = val

    # ---- initial state: at rest at q = 0, the transmission carrying gravity and the load ripple
    y0 = np.zeros(NS)
    tl0 = c["dyn_ripple"] * math.sin(c["dyn_ripple_phase"])
    t20 = tl0 + G0 * c["mr_y"]
    d2 = t20 / c["k2"]
    for _ in range(20):   # Newton on the hardening law
        r = d2 / P[P_D2R]
        f = c["k2"] * d2 * (1 + c["hardening"] * r * r) - t20
        d2 -= f / (c["k2"] * (1 + 3 * c["hardening"] * r * r))
    d1 = t20 / c["k1"]
    y0[S_TH] = d2
    y0[S_U] = d2 + d1
    y0[S_XIW] = t20 / P[P_KIW]
    y0[S_I1] = y0[S_I2] = y0[S_I3] = t20 / (3 * REDUCTION * 1.6)
    y0[S_TJ] = tj0
    y0[S_PH] = P_SET
    y0[S_LF] = tl0
    P[P_U0] = y0[S_U]

    # ---- noise, always drawn in the same order (independent of the effects)
    wcd, wcm = P[P_WCD], P[P_WCM]
    wd = rng.standard_normal(n_int + 1) * DYN_NOISE_SD * math.sqrt(2.0 / (wcd * h))
    wm = rng.standard_normal(n_int + 1) * MOTOR_NOISE_SD * math.sqrt(2.0 / (wcm * h))
    wp = rng.standard_normal(n_int + 1) * 15e3 * math.sqrt(2.0 * P[P_TAUP] / h)
    tm0 = tj0 + rng.uniform(1.0, 4.0, 3)
    y0[S_TM1], y0[S_TM2], y0[S_TM3] = tm0
    e_torque = rng.standard_normal(n)
    e_load = rng.standard_normal(n)
    e_qd = rng.standard_normal(n)
    e_ud = rng.standard_normal(n)
    e_i = rng.standard_normal((3, n))
    e_w = rng.standard_normal((3, n))
    e_tm = rng.standard_normal((3, n))
    e_tj = rng.standard_normal(n)
    e_hyd = rng.standard_normal((3, n))
    e_rw = rng.standard_normal(n)

    # ---- integrate
    log = _integrate(y0, P, tt, vv, ll, fa, fb, n_int, h, wd, wm, wp)
    if not np.all(np.isfinite(log)):
        raise RuntimeError("rig_q: the integration diverged (please report the arguments)")
    idx = np.arange(n) * m

    # ---- torque transducer
    read = fx["read"]
    T_true = log[:, L_T2]
    tj_i = log[:, L_TJ]
    f_cyl = log[:, L_PH] * A_CYL - 300.0
    m_bend_i = f_cyl * ARM_BEND
    tr = _butter_lp(T_true, sensors.torque_bandwidth_hz, h)
    gain = 1.0 + un["torque_gain_error"]
    if "sensor_drift" in read and read["sensor_drift"][0] == "torque_gain":
        gain = gain * (1.0 + 0.006 * read["sensor_drift"][1] * t_i / 60.0)
    tr = tr * gain + un["torque_zero_nm"] + un["torque_zero_tempco_nm_per_k"] * (tj_i - 25.0) \
        + un["bending_crosstalk"] * m_bend_i
    lag_t = sensors.torque_lag_s
    lag_l = 0.0
    if "torque_offset" in read:
        form, sc = read["torque_offset"]
        if form == "constant":
            tr = tr + 400.0 * sc
        elif form == "linear_drift":
            tr = tr + 8.0 * sc * t_i
        elif form == "warmup":
            tr = tr + 500.0 * sc * (1.0 - np.exp(-t_i / 15.0))
        else:
            tr = tr + sc * (150.0 + 12.0 * (tj_i - 15.0))
    if "time_delay" in read:
        form, sc = read["time_delay"]
        if form == "torque":
            lag_t += 0.04 * sc
        elif form == "load_cell":
            lag_l += 0.04 * sc
        else:
            tr = _first_order(tr, 0.03 * sc, h)
    if "pickup" in read:
        tr = tr + read["pickup"] * np.sin(2 * math.pi * 13.7 * t_i + c["disturbance_phase"])
    torque = np.interp(t_s - lag_t, t_i, tr) + sensors.torque_noise * e_torque
    torque = np.round(torque / ADC_LSB) * ADC_LSB

    # ---- load cell
    TL_true = log[:, L_TL]
    lr = _butter_lp(TL_true, sensors.load_bandwidth_hz, h) * (1.0 + un["load_cell_gain_error"]) \
        + un["load_cell_zero_nm"]
    load = np.interp(t_s - lag_l, t_i, lr) + sensors.load_noise * e_load
    if "sensor_drift" in read:
        form, sc = read["sensor_drift"]
        if form == "load_cell_zero":
            load = load + 6.0 * sc * t_s
        elif form == "random_walk":
            steps = e_rw * math.sqrt(1.0 / fs)
            steps[0] = 0.0
            load = load + 60.0 * sc * np.cumsum(steps)
    load = np.round(load / ADC_LSB) * ADC_LSB

    # ---- encoders
    res = math.radians(sensors.encoder_res_deg)
    q_true = log[:, L_Q]
    period_int = 32.0 * res
    q_enc = (q_true + un["encoder_eccentricity_rad"] * np.sin(q_true + un["encoder_eccentricity_phase"])
             + un["encoder_interpolation_frac"] * res
             * np.sin(2 * math.pi * q_true / period_int + un["encoder_interpolation_phase"]))
    q_enc = q_enc - q_enc[0] + q_true[0]
    q_read = np.round(q_enc[idx] / res) * res
    fc_v = min(sensors.velocity_filter_hz, 0.25 * fs)
    v_raw = np.empty_like(q_enc)
    v_raw[1:] = np.diff(q_enc) / h
    v_raw[0] = v_raw[1] if len(v_raw) > 1 else 0.0
    v_f = _butter_lp(v_raw, fc_v, h)
    a_f = _first_order(np.gradient(v_f, h) if len(v_f) > 1 else np.zeros_like(v_f),
                       1.0 / (2 * math.pi * fc_v), h)
    qd_read = v_f[idx] + sensors.velocity_noise * e_qd
    qdd_read = a_f[idx]
    lag_qd = math.sqrt(2.0) / (2 * math.pi * fc_v) + 0.5 * h
    res_u = 2 * math.pi / MOTOR_COUNTS / REDUCTION
    u_true = log[:, L_U]
    u_read = np.round(u_true[idx] / res_u) * res_u
    fc_u = min(50.0, 0.25 * fs)
    ud_f = _first_order(log[:, L_WU], 1.0 / (2 * math.pi * fc_u), h)
    ud_read = ud_f[idx] + 2e-6 * e_ud
    lag_ud = 1.0 / (2 * math.pi * fc_u)

    # ---- drive, thermal, hydraulic channels
    currents = [np.round((log[idx, col] + sensors.current_noise * e_i[k]) / CURRENT_STEP) * CURRENT_STEP
                for k, col in enumerate((L_I1, L_I2, L_I3))]
    w_motor = [REDUCTION * ud_f[idx] + 0.02 * e_w[k] for k in range(3)]
    temps_m = [np.round((log[idx, col] + 0.05 * e_tm[k]) / TEMP_STEP) * TEMP_STEP
               for k, col in enumerate((L_TM1, L_TM2, L_TM3))]
    temp_joint = np.round((tj_i[idx] + 0.03 * e_tj) / TEMP_STEP) * TEMP_STEP
    p_hyd = log[idx, L_PH] + 5e3 * e_hyd[0]
    f_shear = f_cyl[idx] + 150.0 * e_hyd[1]
    m_bend = m_bend_i[idx] + 90.0 * e_hyd[2]

    edges = np.array([p[0] for p in phases])
    labels = np.array([p[1] for p in phases], dtype=object)
    phase = labels[np.minimum(np.searchsorted(edges, t_s, side="right"), len(labels) - 1)]

    samples = pd.DataFrame({
        "t": t_s, "q": q_read, "qd": qd_read, "qdd": qdd_read, "u": u_read, "ud": ud_read,
        "torsion": q_read - u_read, "torque": torque, "torque_load": load,
        "torque_cmd": log[idx, L_TCMD],
        "i_m1": currents[0], "i_m2": currents[1], "i_m3": currents[2],
        "w_m1": w_motor[0], "w_m2": w_motor[1], "w_m3": w_motor[2],
        "temp_m1": temps_m[0], "temp_m2": temps_m[1], "temp_m3": temps_m[2],
        "temp_joint": temp_joint, "p_hyd": p_hyd, "m_bend": m_bend, "f_shear": f_shear,
        "phase": pd.Series(phase, dtype=object),
    })
    truth = pd.DataFrame({
        "t": t_s, "q": q_true[idx], "qd": log[idx, L_WQ], "qdd": log[idx, L_QDD],
        "u": u_true[idx], "ud": log[idx, L_WU], "twist": u_true[idx] - q_true[idx],
        "torque": T_true[idx], "torque_load": TL_true[idx], "torque_cmd": log[idx, L_TCMD],
        "torque_motor": log[idx, L_TM], "torque_stage1": log[idx, L_T1],
        "friction": log[idx, L_FO], "gravity": log[idx, L_G], "temp_joint": tj_i[idx],
        "hysteresis_state": log[idx, L_XH],
    })

    start = datetime(2026, 1, 5, 8, 0, tzinfo=UTC) + timedelta(days=seed % 360,
                                                                         minutes=15 * run)
    meta = {
        "scheme": scheme,
        "motor_speed_rpm": rpm,
        "direction": direction,
        "reduction": REDUCTION,
        "rig": "CMOR J4 bench (validation rig Q)",
        "source": "emulator",
        "sample_rate_hz": fs,
        "started_at": start.strftime("%Y-%m-%dT%H:%M:%SZ"),
        "notes": (f"rig_q scheme {scheme}" + ("" if rpm is None else f" at {rpm:g} r/min")
                  + f", direction {direction:+d}, joint {tj0:g} degC"
                  + (f", {periods} Fourier periods of {FOURIER_PERIOD:g} s" if scheme == 3 else "")),
        "sensors": {
            "q": {"resolution": res},
            "qd": {"noise_sd": float(sensors.velocity_noise), "lag_s": lag_qd},
            "u": {"resolution": res_u},
            "ud": {"noise_sd": 2e-6, "lag_s": lag_ud},
            "torque": {"noise_sd": float(sensors.torque_noise), "lag_s": float(sensors.torque_lag_s),
                       "resolution": ADC_LSB},
            "torque_load": {"noise_sd": float(sensors.load_noise), "resolution": ADC_LSB},
            "i_m1": {"noise_sd": float(sensors.current_noise), "resolution": CURRENT_STEP},
            "i_m2": {"noise_sd": float(sensors.current_noise), "resolution": CURRENT_STEP},
            "i_m3": {"noise_sd": float(sensors.current_noise), "resolution": CURRENT_STEP},
            "temp_joint": {"noise_sd": 0.03, "resolution": TEMP_STEP},
        },
    }
    if scheme == 3:
        meta["periods"] = periods

    params = {k: v for k, v in c.items() if k != "unstated"}
    params["unstated"] = dict(un)
    params.update({
        "seed": seed, "run": run, "internal_step_s": h, "steps_per_sample": m,
        "effects": {k: {"form": f, "scale": sc} for k, (f, sc) in eff.items()},
        "k_total_small_load": 1.0 / (1.0 / c["k1"] + 1.0 / c["k2"]),
        "T_rated": T_RATED, "N1": N1, "N2": N2,
    })
    return RigRun(samples=samples, meta=meta, truth=truth, params=params)
