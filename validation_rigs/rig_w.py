"""Validation rig W: an independent model of the CFETR CMOR J4 joint test bench.

Written blind (from the paper, rig.md, run-format.md and effects-in-the-wild.md only) to score a
sim-to-real diagnosis; it shares no code with the repository's emulator or diagnosis.
SI units throughout (temperatures in degC). Sign conventions as rig.md: ``q`` output angle,
``u`` motor angle / N, twist ``Delta = u - q`` (the run format's ``torsion = q - u``), ``T``
the transmitted torque, ``tau_L`` the loader torque on the output (positive = paper's positive
loading).

Data sheet
==========

Machine (campaign values are drawn around these with a small spread fixed by ``seed``)
---------------------------------------------------------------------------------------
* Output body, paper Eq. 4 / Table 3: ``I*qdd = T - tau_L - g*(mr_x sin q + mr_y cos q)
  - F_fric``; I = 6685.2 kg m^2 (sd 1 %), mr_x = 20.78 kg m, mr_y = -34.54 kg m (sd 3 %),
  g = 9.81. Nominal friction in steady sliding ``F_fric = f_v*qd + f_c*sgn(qd)`` with
  f_v = 8683.3 N m s/rad, f_c = 2352.7 N m (sd 1 % each).
* Output friction: Generalized Maxwell-Slip (Al-Bender, Lampaert & Swevers 2005), 4 elementary
  slip blocks in parallel plus viscous ``f_v*qd``. Block i (fraction a_i = .35/.30/.20/.15,
  break-away displacement d_i = 4/12/30/70 urad, stiffness k_i = a_i*f_c/d_i, micro-damping
  c_i = 0.1*sqrt(k_i*I) while sticking): sticking ``dF_i/dt = k_i*qd`` until
  ``|F_i| >= a_i*s(v)``; slipping ``dF_i/dt = (C/s(v))*(d*a_i*s(v) - F_i)`` (C = f_c/4 ms,
  d the slip direction) until the velocity reverses. Steady sliding: ``sum F_i = s(v)*sgn v``,
  the sliding level s(v) = f_c nominally (every friction effect below acts through s(v) or f_v).
  Hence presliding (a ~1e-4 rad spring-like zone with non-local memory) and stiction at every
  reversal: the output sticks while the motor winds the transmission up.
* Transmission (precision reducer + differential planetary, N = 11000): two compliances in
  series, a linear shaft/carrier stage k1 = 2.0e7 N m/rad and a Hertzian tooth-contact stage
  whose deflection grows as load^(2/3) from a mesh preload T_p = 20 kN m:
  ``Delta(T) = T/k1 + c_h*((|T|+T_p)^(2/3) - T_p^(2/3))*sgn T``, with
  ``c_h = c_h0*(1 + 0.12*M_b/250 kN m)`` (the output bearing tilts under the hydraulic bending
  moment M_b and narrows the contact band). At the bench's constant M_b = 135 kN m,
  c_h = 1.4744e-6 rad/(N m)^(2/3): secant stiffness 1.35e7 N m/rad at 120 kN m (twist 0.509 deg),
  tangent 1.16e7 at zero torque rising to 1.45e7 at 120 kN m (-14 %/+7.5 % of the secant).
  ``T = T_e(Delta) + D*dDelta/dt`` with T_e the inverse law (Newton, exact to rounding) and
  D = 6.0e4 N m s/rad; first order ``T ~= k*Delta`` (paper Eq. 5).
* Drive: 3 servo motors (rotor 4e-4 kg m^2 each, first stage 3e-4 kg m^2; referred to the
  output J_u = N^2*1.5e-3 = 1.815e5 kg m^2) on one summing pinion. One speed loop (PI,
  Kp = 0.09 N m s/rad, Ki = 1.35 N m/rad at the motor shaft; scheme 3 adds a position loop
  4 1/s on the motor encoder) gives a total torque command shared equally; each S120 current
  loop is a 1 ms first-order lag, limit 8 A; k_t = 1.4 N m/A nominal, each motor's actual k_t
  off by sd 1.5 %. Motor-side friction 0.12 N m*tanh(w/0.5) + 1.5e-4*w (at the motor shaft).
  ``J_u*du_dot/dt = N*(sum k_t,i*i_i - tau_fm) - T``.
* Loader: electric dynamometer (servo + reducer, inertia referred to the output
  J_d = 1.2e4 kg m^2, viscous 1500 N m s/rad) on a loading shaft k_s = 5.0e6 N m/rad,
  c_s = 1.5e4 N m s/rad; the load cell reads the shaft torque
  ``tau_L = k_s*(q - th_d) + c_s*(qd - w_d)``. Cascade control: a PLC torque loop
  ``w_ref = qd + 1.6e-6*(tau_L - tau_set) + 2.4e-6*int(tau_L - tau_set)`` (the joint's speed
  fed forward from the output encoder) over the drive's speed loop
  ``tau_dm,cmd = tau_set + 3e5*(w_d - w_ref)``, torque (current) loop lag 4 ms.
* Hydraulics: the cylinder holds a constant shear 90 kN at a 1.5 m lever (bending 135 kN m,
  pressure 4.48 MPa on a 160 mm bore) in every run, settling within +-0.4 % of it per run.
* Thermal: gearbox node 2.5e4 J/K, 0.15 K/W to a 22 degC hall, heated by the output friction
  power and the motor-side friction power; each winding 600 J/K, 1.1 Ohm, 0.8 K/W, starting
  1.5 degC above the gearbox. ``temp_joint_c`` is the gearbox temperature at t = 0.

Schemes (the bench's own programs)
---------------------------------
* 1 (70 s): idle 1 s at rest; speed ramp (cosine) to ``direction*rpm`` over 2 s; load ramp
  0 -> 120 kN m in 30 s; hold 4 s; unload ramp 30 s; stop over 2 s; idle 1 s. The loader always
  loads positively, so direction -1 runs are back-driven (the load overhauls the joint).
* 2 (70 s): as 1 but the load rises in 12 steps of +10 kN m, each loaded "slowly" (paper) in a
  0.5 s ramp (phase ``load``) and held 2 s (``hold``); hold to t = 37 s; then 12 steps of
  -10 kN m (``unload`` 0.5 s + ``hold`` 2 s).
* 3 (``periods`` x 20 s, phase ``excite``): paper Eq. 12, 5 harmonics, w_f = 2 pi/20 s, starting
  at rest (sum a_l = 0, sum l*b_l = 0, q(0) = 0), coefficients minimising the log condition
  number of Eq. 4's column-normalised observation matrix, peak output speed 0.9*3000 r/min / N;
  ``q_ref -> direction*q_ref``; loader at zero torque set point.
* Every scheme starts at rest at q = 0 with the output encoder zeroed.

Integrator
----------
Linearly implicit 2-stage Rosenbrock-W method ROS2 (Verwer, Spee, Blom & Hundsdorfer 1999,
gamma = 1 + 1/sqrt 2, L-stable, order 2 for any Jacobian), non-autonomous terms by a
finite-difference f_t; the Jacobian by finite differences, refreshed every 5 steps and at every
stick/slip switch (its LU, own code with partial pivoting, reused in between: the W property
keeps the order); numba ``@njit(cache=True)``. Fixed inner step h <= 1 ms (<= 0.25 ms with the
motor-angle ripple), an integer divisor of the sample period, so the state is sampled exactly at
the sample instants. The GMS stick/slip flags switch between steps. Thermal nodes are advanced
explicitly (time constants of minutes).

Sensors (``SensorSpec``; what ``meta["sensors"]`` states)
--------------------------------------------------------
* ``q``: output encoder, quantised (rounded) at ``encoder_res_deg`` (default 0.01 deg, Table 10).
* ``u``: motor-1 encoder, 2^``motor_encoder_bits`` counts/rev (default 20), divided by N.
* ``torque``: strain-gauge transducer on the output stage; amplifier = 2nd-order Bessel low-pass
  ``3/((s*tau)^2 + 3*s*tau + 3)`` whose DC group delay tau = ``torque_lag_s`` (stated lag,
  default 0.01 s), then Gaussian noise ``torque_noise`` (default 150 N m) and an ADC step
  ``torque_adc_step`` (default 5 N m).
* ``torque_load``: load cell, first-order amplifier with time constant (= stated lag)
  ``load_lag_s`` (default 0.005 s), noise ``load_noise`` (default 80 N m), step 5 N m.
* ``i_m1..3`` (noise ``current_noise``, step 1 mA), ``w_m1..3`` (noise 0.05 rad/s, step
  1e-3 rad/s), temperatures (noise 0.05 degC, step 0.1 degC), ``p_hyd`` (noise 5 kPa),
  ``m_bend`` (noise 150 N m), ``f_shear`` (noise 100 N), ``torque_cmd`` (the set point, exact),
  ``torsion = q - u`` of the readings, ``phase``.
* Noise: ``np.random.default_rng([seed, run, 1])``, drawn in a fixed order whatever the effects.

Unstated imperfections (always on unless ``simulate_run(..., unstated=False)``; drawn per seed)
---------------------------------------------------------------------------------------------
* ``asymmetric_friction``: the sliding level is higher for negative velocity by 2-3.5 % of f_c
  (47-82 N m).
* ``gear_ripple``: a 96-per-output-revolution mesh torque ripple on the output body,
  25-45 N m, random phase.
* ``torque_offset``: the torque transducer's zero is off by +-(40-90) N m (constant).

Effects (``effects={name: {"form": f, "scale": s}}``, 0 <= s <= SCALE_MAX; s multiplies the size)
-----------------------------------------------------------------------------------------------
v = qd, theta = gearbox temperature [degC], theta_ref = 35 degC, T_r = 120 kN m; "s +=" adds
to the GMS sliding level, "f_v *=" scales the viscous coefficient; levels floored at 0.2*f_c.

* ``stribeck`` (dS = 400 N m, v_s = 5e-3 rad/s = 17 % of top speed, r = |v|/v_s):
  s += scale*dS*phi(r) with ``exp1`` phi = exp(-r); ``gauss`` exp(-r^2); ``lorentz``
  1/(1+r^2); ``exp_half`` exp(-sqrt r).
* ``load_dependent_friction``: ``coulomb`` s += scale*0.003*|T| (360 N m at T_r);
  ``coulomb_viscous`` s += scale*0.002*|T| and f_v *= 1 + scale*0.6*|T|/T_r;
  ``power_flow`` s += scale*|T|*(0.001 + 0.003*(1 + tanh(T*d/1 kN m))/2) (0.004 driving,
  0.001 back-driven).
* ``temperature_friction``: ``coulomb_additive`` s += scale*12*(theta_ref - theta) N m;
  ``viscous_exp`` f_v *= exp(-scale*0.03*(theta - theta_ref));
  ``both_linear`` s and f_v *= max(0.2, 1 - scale*0.008*(theta - theta_ref));
  ``viscous_vogel`` f_v *= exp(scale*500 K*(1/(theta+93.15) - 1/(theta_ref+93.15))).
* ``gear_ripple`` (z = 96 per output revolution): ``output_harmonics`` torque on the output
  body scale*250*(sin(z q + 0.4) + 0.4 sin(2 z q + 1.9)) N m; ``motor_angle`` angle error in the
  transmission ``Delta -> Delta - e``, e = scale*2e-5*(sin(2 th_m + 0.3) + 0.3 sin(4 th_m + 2.2))
  rad, th_m = N*u (2 and 4 cycles per motor revolution, ~270 N m of torque ripple);
  ``load_modulated`` torque scale*250*(0.25 + |T|/T_r)*sin(z q + 0.4) N m;
  ``output_angle_error`` angle error e = scale*2e-5*sin(z q + 0.4) rad.
* ``torque_offset`` (on the ``torque`` reading only): ``constant`` scale*250 N m;
  ``linear_drift`` scale*4 N m/s * t; ``settling`` scale*300*(1 - exp(-t/12 s)) N m;
  ``thermal`` scale*12*(theta - 35) N m.
* ``time_delay`` (readings only): ``torque_lag`` pure delay scale*20 ms of ``torque``;
  ``torque_filter`` an extra first-order lag scale*20 ms on ``torque``; ``encoder_lag``
  pure delay scale*5 ms of ``q``.
* ``hysteresis`` (in the twist-torque law, T += scale*400 N m * x, dx/dt from
  r = dDelta/dt / 3e-4 rad): ``bouc_wen_n1`` r*(1 - (0.7 sgn(r x) + 0.3)|x|);
  ``bouc_wen_n3`` r*(1 - (0.5 sgn(r x) + 0.5)|x|^3); ``dahl_r2`` r*z|z|, z = 1 - x sgn r;
  ``jenkins`` r*(1 - max(x sgn r, 0)^12) (an almost sharp elasto-plastic loop).
* ``backlash`` (b = scale*2.5e-5 rad half-width, applied to Delta before T_e): ``sharp``
  dead zone; ``smooth`` 0.5[(D-b)+sqrt((D-b)^2+w^2)] + 0.5[(D+b)-sqrt((D+b)^2+w^2)],
  w = 5e-6 rad; ``soft_zone`` slope 0.15 inside +-b (a lost motion taken up by a soft spring).
* ``asymmetric_friction``: ``coulomb_neg`` s += scale*300 N m for v < 0; ``viscous_pos``
  f_v *= 1 + scale*0.8 for v > 0; ``both`` s += scale*200 N m and f_v *= 1 + scale*0.5 for
  v < 0; ``offset`` a constant torque scale*250 N m on the output body (not gravity).

Out of vocabulary
-----------------
* ``periodic_disturbance`` (torque on the output, A = scale*300 N m): ``sine`` A sin(2 pi 0.9 t);
  ``pulse`` raised-cosine pulses of 0.5 s every 3 s of height A; ``beat``
  A sin(2 pi 1.3 t) sin(2 pi 0.11 t).
* ``position_stiffness`` (T_e *= 1 + scale*0.006*shape(q)): ``once_per_rev`` cos(q - 0.3);
  ``twice_per_rev`` cos(2q + 0.7); ``sector`` -exp(-((q - 0.06)/0.05)^2).
* ``second_resonance`` (a body J2 = scale*2500 kg m^2 on a spring tuned to 11 Hz alone,
  damping 2 %, coupling with the bench's own modes): ``output`` hung on the output body (a
  flexible tool flange); ``loader`` hung on the dynamometer (its coupling hub).
* ``encoder_eccentricity`` (``q`` reading only): ``once_per_rev`` + scale*4e-5*sin(q + 0.5) rad;
  ``scale_error`` + scale*2e-4*q.
* ``loadcell_drift`` (``torque_load`` reading only): ``linear`` scale*4 N m/s * t;
  ``settling`` scale*300*(1 - exp(-t/15 s)) N m.

Sizes: scale 1 is "noticeable but small" (a few hundred N m on the output balance or a few
1e-5 rad in the twist); effects are linear in scale for small scale and vanish at scale 0 (a
scale-0 effect is dropped before simulating). Sensor-only effects (torque_offset, time_delay,
encoder_eccentricity, loadcell_drift) act after the simulation and never touch the truth.
"""

from __future__ import annotations

import math
from collections import OrderedDict
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np
import pandas as pd
from numba import njit
from scipy.linalg import expm

RIG_NAME = "rig_w"
REDUCTION = 11000.0
SEED_IS_CAMPAIGN = True
SCALE_MAX = 10.0

EFFECT_FORMS: dict[str, tuple[str, ...]] = {
    "stribeck": ("exp1", "gauss", "lorentz", "exp_half"),
    "load_dependent_friction": ("coulomb", "coulomb_viscous", "power_flow"),
    "temperature_friction": ("coulomb_additive", "viscous_exp", "both_linear", "viscous_vogel"),
    "gear_ripple": ("output_harmonics", "motor_angle", "load_modulated", "output_angle_error"),
    "torque_offset": ("constant", "linear_drift", "settling", "thermal"),
    "time_delay": ("torque_lag", "torque_filter", "encoder_lag"),
    "hysteresis": ("bouc_wen_n1", "bouc_wen_n3", "dahl_r2", "jenkins"),
    "backlash": ("sharp", "smooth", "soft_zone"),
    "asymmetric_friction": ("coulomb_neg", "viscous_pos", "both", "offset"),
    "periodic_disturbance": ("sine", "pulse", "beat"),
    "position_stiffness": ("once_per_rev", "twice_per_rev", "sector"),
    "second_resonance": ("output", "loader"),
    "encoder_eccentricity": ("once_per_rev", "scale_error"),
    "loadcell_drift": ("linear", "settling"),
}

OUT_OF_VOCABULARY: tuple[str, ...] = (
    "periodic_disturbance", "position_stiffness", "second_resonance", "encoder_eccentricity",
    "loadcell_drift")

UNSTATED_VOCABULARY: dict[str, str] = {
    "asymmetric_friction": "sliding friction higher for negative velocity by 2-3.5 % of f_c",
    "gear_ripple": "96-per-revolution mesh torque ripple of 25-45 N m on the output body",
    "torque_offset": "torque transducer zero off by 40-90 N m (either sign)",
}

SENSOR_ONLY: tuple[str, ...] = ("torque_offset", "time_delay", "encoder_eccentricity",
                                "loadcell_drift")
"""Effects that act on readings only (applied after the simulation)."""

# --- effect indices and sizes (compile-time constants of the kernel) ------------------------
_EFFECT_ORDER = tuple(EFFECT_FORMS)
E_STRIB, E_LOAD, E_TEMP, E_RIPPLE, E_OFFSET, E_DELAY, E_HYST, E_BACKLASH, E_ASYM, \
    E_PDIST, E_PSTIFF, E_RES2, E_ECC, E_LCDRIFT = range(14)
N_EFFECTS = 14

STRIB_DS = 400.0
STRIB_VS = 5.0e-3
LD_MU = 0.003
LD_MU2 = 0.002
LD_KV = 0.6
LD_MU_D = 0.004
LD_MU_B = 0.001
LD_T0 = 1000.0
T_RATED = 120.0e3
TF_REF = 35.0
TF_CA = 12.0
TF_A = 0.03
TF_KL = 0.008
TF_B = 500.0
TF_T0 = 180.0
RIP_Z = 96.0
RIP_A = 250.0
RIP_PH1 = 0.4
RIP_PH2 = 1.9
RIP_MA = 2.0e-5
RIP_PHM1 = 0.3
RIP_PHM2 = 2.2
RIP_OAE = 2.0e-5
OFF_C = 250.0
OFF_RATE = 4.0
OFF_SET_A = 300.0
OFF_SET_TAU = 12.0
OFF_THERM = 12.0
DL_TORQUE = 0.020
DL_FILTER = 0.020
DL_ENC = 0.005
HY_H = 400.0
HY_DELTA = 3.0e-4
BL_B = 2.5e-5
BL_W = 5.0e-6
BL_RHO = 0.15
AS_C = 300.0
AS_V = 0.8
AS_C2 = 200.0
AS_V2 = 0.5
AS_OFF = 250.0
PD_A = 300.0
PD_F = 0.9
PD_PERIOD = 3.0
PD_WIDTH = 0.5
PD_F1 = 1.3
PD_F2 = 0.11
PS_EPS = 0.006
R2_F = 11.0
R2_ZETA = 0.02
R2_J_OUT = 2500.0
R2_J_LOAD = 2500.0
ECC_E = 4.0e-5
ECC_PH = 0.5
ECC_SCALE = 2.0e-4
LC_RATE = 4.0
LC_A = 300.0
LC_TAU = 15.0
S_FLOOR = 0.2
H_MAX = 1.0e-3
H_MAX_RIPPLE = 2.5e-4
JAC_EVERY = 5

# --- state, auxiliary and parameter indices ------------------------------------------------
Y_U, Y_W, Y_Q, Y_QD, Y_I1, Y_I2, Y_I3, Y_XIS = 0, 1, 2, 3, 4, 5, 6, 7
Y_F0 = 8  # 8..11: GMS block forces
Y_THD, Y_WD, Y_XIT, Y_TDM, Y_XH, Y_Y2, Y_Y2D = 12, 13, 14, 15, 16, 17, 18
NS = 19
N_GMS = 4

A_T, A_TS, A_FF, A_G, A_TSET, A_WREF, A_TE, A_HYS, A_TRIP, A_TDIST, A_QDD, A_TAUM, A_DEFF, \
    A_SPOS, A_SNEG, A_FV, A_TABS, A_C0, A_QREF, A_PLOSS, A_TFM = range(21)
NA = 21

(P_I, P_MRX, P_MRY, P_G, P_FV, P_FC, P_K1, P_CH, P_TP, P_D, P_N, P_JU, P_JIN, P_KT1, P_KT2,
 P_KT3, P_KTN, P_TAUC, P_IMAX, P_KPS, P_KIS, P_KPOS, P_FCM, P_FVM, P_WEPS) = range(25)
P_GA0 = 25   # 25..28 GMS fractions
P_GK0 = 29   # 29..32 GMS stiffnesses
P_GC0 = 33   # 33..36 GMS micro-damping
(P_GATT, P_KS, P_CS, P_JD, P_BD, P_TAUCD, P_KWD, P_KTP, P_KTI, P_TDMAX, P_SCHEME, P_DIR,
 P_WREF, P_TLOAD, P_TF) = range(37, 52)
P_FA0 = 52   # 52..56 Fourier a_l
P_FB0 = 57   # 57..61 Fourier b_l
(P_FQ0, P_USYM, P_URA, P_URPH, P_CG, P_RG, P_TAMB, P_CW, P_RW, P_RWA, P_DUR) = range(62, 73)
NP = 73

# --- the bench's fixed design values ------------------------------------------------------
G = 9.81
TABLE3 = {"I": 6685.166, "mr_x": 20.779, "mr_y": -34.543, "f_v": 8683.272, "f_c": 2352.660}
K1 = 2.0e7
TP = 2.0e4
M_BEND = 135.0e3
SHEAR = 90.0e3
LEVER = 1.5
BORE_AREA = math.pi * 0.080 ** 2
TILT_K = 0.12
TILT_MREF = 250.0e3
CH_EFF = 1.4743793582719652e-6       # c_h at M_BEND: secant 1.35e7 N m/rad at 120 kN m
CH0 = CH_EFF / (1.0 + TILT_K * M_BEND / TILT_MREF)
DAMP_T = 6.0e4
J_ROTOR = 4.0e-4
J_STAGE1 = 3.0e-4
KT_NOM = 1.4
GMS_ALPHA = (0.35, 0.30, 0.20, 0.15)
GMS_DISP = (4.0e-6, 1.2e-5, 3.0e-5, 7.0e-5)
GMS_ZETA = 0.05
GMS_TATT = 0.004
SCHED = {"idle0": 1.0, "spin": 2.0, "load": 30.0, "hold": 4.0, "unload": 30.0, "stop": 2.0,
         "end": 70.0}
T_EXC = 20.0
# Fourier coefficients (scheme 3), optimised offline; a_5, b_5 follow from starting at rest.
_FA = (-0.00557833, -0.00504816, 0.00362364, 0.00629209)
_FB = (-0.00248147, 0.00548193, 0.00617155, -0.00169824)


def _fourier_coeffs() -> tuple[np.ndarray, np.ndarray, float]:
    a = np.array(_FA + (-sum(_FA),))
    b4 = np.array(_FB)
    b = np.append(b4, -float(np.dot(b4, np.arange(1, 5))) / 5.0)
    wf = 2.0 * math.pi / T_EXC
    ll = np.arange(1, 6)
    q0 = float(np.sum(b / (wf * ll)))
    return a, b, q0


# ============================================================================================
# the numba kernel
# ============================================================================================

@njit(cache=True)
def _sgn(x):
    if x > 0.0:
        return 1.0
    if x < 0.0:
        return -1.0
    return 0.0


@njit(cache=True)
def _speed_profile(t):
    t1 = 1.0
    t2 = 3.0
    t3 = 67.0
    t4 = 69.0
    if t <= t1 or t >= t4:
        return 0.0
    if t < t2:
        return 0.5 * (1.0 - math.cos(math.pi * (t - t1) / (t2 - t1)))
    if t <= t3:
        return 1.0
    return 0.5 * (1.0 + math.cos(math.pi * (t - t3) / (t4 - t3)))


@njit(cache=True)
def _load_profile(t, scheme, tl):
    if scheme == 1:
        if t <= 3.0:
            return 0.0
        if t <= 33.0:
            return tl * (t - 3.0) / 30.0
        if t <= 37.0:
            return tl
        if t <= 67.0:
            return tl * (67.0 - t) / 30.0
        return 0.0
    # scheme 2: 12 steps of tl/12 up, hold, 12 steps down
    step = tl / 12.0
    if t <= 3.0:
        return 0.0
    if t < 33.0:
        k = math.floor((t - 3.0) / 2.5)
        x = (t - 3.0 - 2.5 * k) / 0.5
        return step * (k + min(x, 1.0))
    if t < 37.0:
        return tl
    if t < 67.0:
        k = math.floor((t - 37.0) / 2.5)
        x = (t - 37.0 - 2.5 * k) / 0.5
        return tl - step * (k + min(x, 1.0))
    return 0.0


@njit(cache=True)
def _refs(t, u, P):
    """(motor speed reference [rad/s at the motor], q_ref, qd_ref, loader set point)."""
    scheme = P[P_SCHEME]
    dirn = P[P_DIR]
    n = P[P_N]
    if scheme < 2.5:
        w = dirn * P[P_WREF] * _speed_profile(t)
        return w, 0.0, w / n, _load_profile(t, int(scheme), P[P_TLOAD])
    wf = 2.0 * math.pi / P[P_TF]
    qr = P[P_FQ0]
    qdr = 0.0
    for l in range(5):
        lw = wf * (l + 1)
        a = P[P_FA0 + l]
        b = P[P_FB0 + l]
        s = math.sin(lw * t)
        c = math.cos(lw * t)
        qr += a / lw * s - b / lw * c
        qdr += a * c + b * s
    qr *= dirn
    qdr *= dirn
    w = n * (qdr + P[P_KPOS] * (qr - u))
    return w, qr, qdr, 0.0


@njit(cache=True)
def _hertz_g(T, ch, tp):
    return ch * (np.cbrt(T + tp) ** 2 - np.cbrt(tp) ** 2)


@njit(cache=True)
def _te_of_delta(d, k1, ch, tp):
    """Inverse of Delta(T) = T/k1 + c_h((|T|+T_p)^(2/3) - T_p^(2/3)) sgn T (Newton from below:
    the law is concave for T > 0, so the iterates rise monotonically to the root)."""
    a = abs(d)
    if a == 0.0:
        return 0.0
    kmin = 1.0 / (1.0 / k1 + (2.0 / 3.0) * ch / np.cbrt(tp))
    T = a * kmin
    for _ in range(40):
        cb = np.cbrt(T + tp)
        g = T / k1 + ch * (cb * cb - np.cbrt(tp) ** 2) - a
        gp = 1.0 / k1 + (2.0 / 3.0) * ch / cb
        dT = -g / gp
        T += dT
        if abs(dT) <= 1e-13 * (T + 1.0):
            break
    return T if d > 0.0 else -T


@njit(cache=True)
def _slide_level(absv, d, T, thg, P, EF, SC):
    """GMS sliding level s (Coulomb + effects) for motion in direction d (+1/-1)."""
    fc = P[P_FC]
    s = fc
    if d < 0.0:
        s += P[P_USYM]
    f = EF[E_STRIB]
    if f >= 0:
        r = absv / STRIB_VS
        if f == 0:
            phi = math.exp(-r)
        elif f == 1:
            phi = math.exp(-r * r)
        elif f == 2:
            phi = 1.0 / (1.0 + r * r)
        else:
            phi = math.exp(-math.sqrt(r))
        s += SC[E_STRIB] * STRIB_DS * phi
    f = EF[E_LOAD]
    if f >= 0:
        aT = abs(T)
        if f == 0:
            s += SC[E_LOAD] * LD_MU * aT
        elif f == 1:
            s += SC[E_LOAD] * LD_MU2 * aT
        else:
            blend = 0.5 * (1.0 + math.tanh(T * d / LD_T0))
            s += SC[E_LOAD] * aT * (LD_MU_B + (LD_MU_D - LD_MU_B) * blend)
    f = EF[E_ASYM]
    if f >= 0 and d < 0.0:
        if f == 0:
            s += SC[E_ASYM] * AS_C
        elif f == 2:
            s += SC[E_ASYM] * AS_C2
    f = EF[E_TEMP]
    if f == 0:
        s += SC[E_TEMP] * TF_CA * (TF_REF - thg)
    elif f == 2:
        s *= max(S_FLOOR, 1.0 - SC[E_TEMP] * TF_KL * (thg - TF_REF))
    return max(s, S_FLOOR * fc)


@njit(cache=True)
def _viscous(v, T, thg, P, EF, SC):
    fv = P[P_FV]
    f = EF[E_LOAD]
    if f == 1:
        fv *= 1.0 + SC[E_LOAD] * LD_KV * abs(T) / T_RATED
    f = EF[E_TEMP]
    if f == 1:
        fv *= math.exp(-SC[E_TEMP] * TF_A * (thg - TF_REF))
    elif f == 2:
        fv *= max(S_FLOOR, 1.0 - SC[E_TEMP] * TF_KL * (thg - TF_REF))
    elif f == 3:
        fv *= math.exp(SC[E_TEMP] * TF_B * (1.0 / (thg + 273.15 - TF_T0)
                                            - 1.0 / (TF_REF + 273.15 - TF_T0)))
    f = EF[E_ASYM]
    if f == 1 and v > 0.0:
        fv *= 1.0 + SC[E_ASYM] * AS_V
    elif f == 2 and v < 0.0:
        fv *= 1.0 + SC[E_ASYM] * AS_V2
    return fv


@njit(cache=True)
def _eval(t, y, P, EF, SC, stick, dirn, thg, dy, aux):
    """Right-hand side dy = f(t, y) for frozen stick/slip flags; aux gets the named forces."""
    n = P[P_N]
    u = y[Y_U]
    w = y[Y_W]
    q = y[Y_Q]
    qd = y[Y_QD]
    wref_m, qref, qdref, tset = _refs(t, u, P)

    # --- transmission ---
    delta = u - q
    e = 0.0
    f = EF[E_RIPPLE]
    if f == 1:
        thm = n * u
        e = SC[E_RIPPLE] * RIP_MA * (math.sin(2.0 * thm + RIP_PHM1)
                                     + 0.3 * math.sin(4.0 * thm + RIP_PHM2))
    elif f == 3:
        e = SC[E_RIPPLE] * RIP_OAE * math.sin(RIP_Z * q + RIP_PH1)
    d1 = delta - e
    f = EF[E_BACKLASH]
    if f >= 0:
        b = SC[E_BACKLASH] * BL_B
        if f == 0:
            if d1 > b:
                de = d1 - b
            elif d1 < -b:
                de = d1 + b
            else:
                de = 0.0
        elif f == 1:
            dm = d1 - b
            dp = d1 + b
            de = 0.5 * (dm + math.sqrt(dm * dm + BL_W * BL_W)) \
                + 0.5 * (dp - math.sqrt(dp * dp + BL_W * BL_W))
        else:
            if d1 > b:
                de = d1 - (1.0 - BL_RHO) * b
            elif d1 < -b:
                de = d1 + (1.0 - BL_RHO) * b
            else:
                de = BL_RHO * d1
    else:
        de = d1
    te = _te_of_delta(de, P[P_K1], P[P_CH], P[P_TP])
    f = EF[E_PSTIFF]
    if f >= 0:
        if f == 0:
            shp = math.cos(q - 0.3)
        elif f == 1:
            shp = math.cos(2.0 * q + 0.7)
        else:
            z = (q - 0.06) / 0.05
            shp = -math.exp(-z * z)
        te *= 1.0 + SC[E_PSTIFF] * PS_EPS * shp
    ddelta = w - qd
    hys = 0.0
    dy[Y_XH] = 0.0
    f = EF[E_HYST]
    if f >= 0:
        x = y[Y_XH]
        hys = SC[E_HYST] * HY_H * x
        r = ddelta / HY_DELTA
        if f == 0:
            dy[Y_XH] = r * (1.0 - (0.7 * _sgn(r * x) + 0.3) * abs(x))
        elif f == 1:
            dy[Y_XH] = r * (1.0 - (0.5 * _sgn(r * x) + 0.5) * abs(x) ** 3)
        elif f == 2:
            z = 1.0 - x * _sgn(r)
            dy[Y_XH] = r * z * abs(z)
        else:
            z = max(x * _sgn(r), 0.0)
            dy[Y_XH] = r * (1.0 - z ** 12)
    T = te + P[P_D] * ddelta + hys

    # --- output friction (GMS) ---
    thg_ = thg
    absv = abs(qd)
    s_pos = _slide_level(absv, 1.0, T, thg_, P, EF, SC)
    s_neg = _slide_level(absv, -1.0, T, thg_, P, EF, SC)
    fg = 0.0
    cst = 0.0
    att = P[P_GATT]
    for i in range(N_GMS):
        Fi = y[Y_F0 + i]
        fg += Fi
        if stick[i] == 1:
            dy[Y_F0 + i] = P[P_GK0 + i] * qd
            cst += P[P_GC0 + i]
        else:
            di = dirn[i]
            s = s_pos if di > 0.0 else s_neg
            dy[Y_F0 + i] = (att / s) * (di * P[P_GA0 + i] * s - Fi)
    fv = _viscous(qd, T, thg_, P, EF, SC)
    ff = fg + cst * qd + fv * qd

    # --- other torques on the output body ---
    grav = P[P_G] * (P[P_MRX] * math.sin(q) + P[P_MRY] * math.cos(q))
    trip = P[P_URA] * math.sin(RIP_Z * q + P[P_URPH])
    f = EF[E_RIPPLE]
    if f == 0:
        trip += SC[E_RIPPLE] * RIP_A * (math.sin(RIP_Z * q + RIP_PH1)
                                        + 0.4 * math.sin(2.0 * RIP_Z * q + RIP_PH2))
    elif f == 2:
        trip += SC[E_RIPPLE] * RIP_A * (0.25 + abs(T) / T_RATED) * math.sin(RIP_Z * q + RIP_PH1)
    tdist = 0.0
    f = EF[E_PDIST]
    if f >= 0:
        a = SC[E_PDIST] * PD_A
        if f == 0:
            tdist = a * math.sin(2.0 * math.pi * PD_F * t)
        elif f == 1:
            ph = t - PD_PERIOD * math.floor(t / PD_PERIOD)
            if ph < PD_WIDTH:
                tdist = a * 0.5 * (1.0 - math.cos(2.0 * math.pi * ph / PD_WIDTH))
        else:
            tdist = a * math.sin(2.0 * math.pi * PD_F1 * t) * math.sin(2.0 * math.pi * PD_F2 * t)
    c0 = 0.0
    if EF[E_ASYM] == 3:
        c0 = SC[E_ASYM] * AS_OFF

    # --- shaft, loader ---
    ts = P[P_KS] * (q - y[Y_THD]) + P[P_CS] * (qd - y[Y_WD])

    # --- second resonance ---
    tabs_out = 0.0
    tabs_load = 0.0
    f = EF[E_RES2]
    if f >= 0:
        w2 = 2.0 * math.pi * R2_F
        if f == 0:
            xa = q
            va = qd
            j2 = R2_J_OUT
        else:
            xa = y[Y_THD]
            va = y[Y_WD]
            j2 = R2_J_LOAD
        acc = w2 * w2 * (xa - y[Y_Y2]) + 2.0 * R2_ZETA * w2 * (va - y[Y_Y2D])
        dy[Y_Y2] = y[Y_Y2D]
        dy[Y_Y2D] = acc
        tab = SC[E_RES2] * j2 * acc
        if f == 0:
            tabs_out = tab
        else:
            tabs_load = tab
    else:
        dy[Y_Y2] = 0.0
        dy[Y_Y2D] = 0.0

    qdd = (T - ts - grav - ff - trip - tdist - c0 - tabs_out) / P[P_I]

    # --- drive: speed loop, torque sharing, current loops ---
    wm = n * w
    tfm = P[P_FCM] * math.tanh(wm / P[P_WEPS]) + P[P_FVM] * wm
    ew = wref_m - wm
    tcmd = P[P_KPS] * ew + P[P_KIS] * y[Y_XIS]
    icmd = tcmd / (3.0 * P[P_KTN])
    imax = P[P_IMAX]
    if icmd > imax:
        icmd = imax
    elif icmd < -imax:
        icmd = -imax
    tauc = P[P_TAUC]
    dy[Y_I1] = (icmd - y[Y_I1]) / tauc
    dy[Y_I2] = (icmd - y[Y_I2]) / tauc
    dy[Y_I3] = (icmd - y[Y_I3]) / tauc
    taum = P[P_KT1] * y[Y_I1] + P[P_KT2] * y[Y_I2] + P[P_KT3] * y[Y_I3]
    dy[Y_XIS] = ew
    dy[Y_U] = w
    dy[Y_W] = (n * (taum - tfm) - T) / P[P_JU]
    dy[Y_Q] = qd
    dy[Y_QD] = qdd

    # --- dynamometer: torque loop over speed loop over current loop ---
    wd = y[Y_WD]
    wrefd = qd + P[P_KTP] * (ts - tset) + P[P_KTI] * y[Y_XIT]
    tdmc = tset + P[P_KWD] * (wd - wrefd)
    tmx = P[P_TDMAX]
    if tdmc > tmx:
        tdmc = tmx
    elif tdmc < -tmx:
        tdmc = -tmx
    dy[Y_THD] = wd
    dy[Y_WD] = (ts - y[Y_TDM] - P[P_BD] * wd - tabs_load) / P[P_JD]
    dy[Y_XIT] = ts - tset
    dy[Y_TDM] = (tdmc - y[Y_TDM]) / P[P_TAUCD]

    aux[A_T] = T
    aux[A_TS] = ts
    aux[A_FF] = ff
    aux[A_G] = grav
    aux[A_TSET] = tset
    aux[A_WREF] = wref_m
    aux[A_TE] = te
    aux[A_HYS] = hys
    aux[A_TRIP] = trip
    aux[A_TDIST] = tdist
    aux[A_QDD] = qdd
    aux[A_TAUM] = taum
    aux[A_DEFF] = de
    aux[A_SPOS] = s_pos
    aux[A_SNEG] = s_neg
    aux[A_FV] = fv
    aux[A_TABS] = tabs_out + tabs_load
    aux[A_C0] = c0
    aux[A_QREF] = qref
    aux[A_PLOSS] = abs(ff * qd)
    aux[A_TFM] = tfm


@njit(cache=True)
def _lu(M, piv):
    n = M.shape[0]
    for k in range(n):
        p = k
        big = abs(M[k, k])
        for i in range(k + 1, n):
            if abs(M[i, k]) > big:
                big = abs(M[i, k])
                p = i
        piv[k] = p
        if p != k:
            for j in range(n):
                tmp = M[k, j]
                M[k, j] = M[p, j]
                M[p, j] = tmp
        inv = 1.0 / M[k, k]
        for i in range(k + 1, n):
            M[i, k] *= inv
            lik = M[i, k]
            if lik != 0.0:
                for j in range(k + 1, n):
                    M[i, j] -= lik * M[k, j]


@njit(cache=True)
def _lus(M, piv, b):
    n = M.shape[0]
    for k in range(n):
        p = piv[k]
        if p != k:
            tmp = b[k]
            b[k] = b[p]
            b[p] = tmp
    for i in range(n):
        s = b[i]
        for j in range(i):
            s -= M[i, j] * b[j]
        b[i] = s
    for i in range(n - 1, -1, -1):
        s = b[i]
        for j in range(i + 1, n):
            s -= M[i, j] * b[j]
        b[i] = s / M[i, i]


@njit(cache=True)
def _gms_update(y, stick, dirn, T, thg, P, EF, SC):
    """Stick/slip switching of the GMS blocks after a step; True when a flag or force changed."""
    qd = y[Y_QD]
    changed = False
    for i in range(N_GMS):
        Fi = y[Y_F0 + i]
        if stick[i] == 1:
            d = 1.0 if Fi >= 0.0 else -1.0
            lim = P[P_GA0 + i] * _slide_level(abs(qd), d, T, thg, P, EF, SC)
            if abs(Fi) >= lim:
                stick[i] = 0
                dirn[i] = d
                y[Y_F0 + i] = d * lim
                changed = True
        else:
            if qd * dirn[i] < 0.0:
                stick[i] = 1
                changed = True
    return changed


_TYP = np.array([1e-2, 1e-3, 1e-2, 1e-3, 1.0, 1.0, 1.0, 1.0,
                 100.0, 100.0, 100.0, 100.0, 1e-2, 1e-3, 1e3, 1e3, 0.1, 1e-2, 1e-3])


@njit(cache=True)
def _simulate(P, EF, SC, n_samp, m, h, y0, stick0, dirn0, th0, typ, jac_every):
    ns = NS
    y = y0.copy()
    stick = stick0.copy()
    dirn = dirn0.copy()
    thg = th0[0]
    thm = th0[1:4].copy()
    n_steps = (n_samp - 1) * m
    S = np.empty((n_samp, ns))
    A = np.empty((n_samp, NA))
    TH = np.empty((n_samp, 5))
    FINE = np.empty((n_steps + 1, 3))
    f0 = np.empty(ns)
    f1 = np.empty(ns)
    ft = np.empty(ns)
    ftmp = np.empty(ns)
    aux = np.empty(NA)
    auxt = np.empty(NA)
    J = np.empty((ns, ns))
    M = np.empty((ns, ns))
    piv = np.empty(ns, dtype=np.int64)
    k1v = np.empty(ns)
    k2v = np.empty(ns)
    yp = np.empty(ns)
    gam = 1.0 + 1.0 / math.sqrt(2.0)
    dte = 1e-6
    n_switch = 0
    jac_age = jac_every

    _eval(0.0, y, P, EF, SC, stick, dirn, thg, f0, aux)
    S[0, :] = y
    A[0, :] = aux
    TH[0, 0] = thg
    TH[0, 1:4] = thm
    TH[0, 4] = stick.sum()
    FINE[0, 0] = aux[A_T]
    FINE[0, 1] = aux[A_TS]
    FINE[0, 2] = y[Y_Q]
    for k in range(n_steps):
        t = k * h
        # time derivative of f
        _eval(t + dte, y, P, EF, SC, stick, dirn, thg, ftmp, auxt)
        for i in range(ns):
            ft[i] = (ftmp[i] - f0[i]) / dte
        # finite-difference Jacobian (a W-method: refreshed every jac_every steps and at
        # every stick/slip switch, its LU reused in between)
        if jac_age >= jac_every:
            for j in range(ns):
                for i in range(ns):
                    yp[i] = y[i]
                ej = 1.5e-8 * max(abs(y[j]), typ[j])
                yp[j] = y[j] + ej
                ej = yp[j] - y[j]
                _eval(t, yp, P, EF, SC, stick, dirn, thg, ftmp, auxt)
                for i in range(ns):
                    J[i, j] = (ftmp[i] - f0[i]) / ej
            for i in range(ns):
                for j in range(ns):
                    M[i, j] = -gam * h * J[i, j]
                M[i, i] += 1.0
            _lu(M, piv)
            jac_age = 0
        jac_age += 1
        for i in range(ns):
            k1v[i] = h * f0[i] + gam * h * h * ft[i]
        _lus(M, piv, k1v)
        for i in range(ns):
            yp[i] = y[i] + k1v[i]
        _eval(t + h, yp, P, EF, SC, stick, dirn, thg, f1, auxt)
        for i in range(ns):
            k2v[i] = h * f1[i] - 2.0 * k1v[i] - gam * h * h * ft[i]
        _lus(M, piv, k2v)
        for i in range(ns):
            y[i] = y[i] + 1.5 * k1v[i] + 0.5 * k2v[i]
        # thermal nodes (explicit; minutes-long time constants)
        ploss = aux[A_PLOSS] + abs(aux[A_TFM] * P[P_N] * y[Y_W])
        thg += h * (ploss - (thg - P[P_TAMB]) / P[P_RG]) / P[P_CG]
        for i in range(3):
            cur = y[Y_I1 + i]
            thm[i] += h * (cur * cur * P[P_RW] - (thm[i] - P[P_TAMB]) / P[P_RWA]) / P[P_CW]
        tn = (k + 1) * h
        _eval(tn, y, P, EF, SC, stick, dirn, thg, f0, aux)
        if _gms_update(y, stick, dirn, aux[A_T], thg, P, EF, SC):
            n_switch += 1
            jac_age = jac_every
            _eval(tn, y, P, EF, SC, stick, dirn, thg, f0, aux)
        FINE[k + 1, 0] = aux[A_T]
        FINE[k + 1, 1] = aux[A_TS]
        FINE[k + 1, 2] = y[Y_Q]
        if (k + 1) % m == 0:
            js = (k + 1) // m
            S[js, :] = y
            A[js, :] = aux
            TH[js, 0] = thg
            TH[js, 1:4] = thm
            TH[js, 4] = stick.sum()
    return S, A, TH, FINE, n_switch


@njit(cache=True)
def _filter2(x, phi, g1, g2):
    """Discrete 2-state linear filter with first-order-hold input, y = state[0]."""
    n = x.shape[0]
    out = np.empty(n)
    s0 = x[0]
    s1 = 0.0
    out[0] = s0
    for k in range(n - 1):
        du = x[k + 1] - x[k]
        n0 = phi[0, 0] * s0 + phi[0, 1] * s1 + g1[0] * x[k] + g2[0] * du
        n1 = phi[1, 0] * s0 + phi[1, 1] * s1 + g1[1] * x[k] + g2[1] * du
        s0 = n0
        s1 = n1
        out[k + 1] = s0
    return out


@njit(cache=True)
def _lowpass1(x, h, tau):
    """Exact first-order lag for a piecewise-linear input, starting at steady state."""
    n = x.shape[0]
    out = np.empty(n)
    out[0] = x[0]
    if tau <= 0.0:
        for k in range(n):
            out[k] = x[k]
        return out
    a = math.exp(-h / tau)
    for k in range(n - 1):
        r = (x[k + 1] - x[k]) / h
        out[k + 1] = (x[k + 1] - tau * r) + (out[k] - x[k] + tau * r) * a
    return out


def _bessel2(x: np.ndarray, h: float, tau: float) -> np.ndarray:
    """2nd-order Bessel low-pass 3/((s tau)^2 + 3 s tau + 3) (DC group delay tau)."""
    if tau <= 0.0:
        return x.copy()
    a = np.array([[0.0, 1.0], [-3.0 / tau ** 2, -3.0 / tau]])
    b = np.array([0.0, 3.0 / tau ** 2])
    big = np.zeros((4, 4))
    big[:2, :2] = a * h
    big[:2, 2] = b * h
    big[2, 3] = 1.0
    e = expm(big)
    return _filter2(np.ascontiguousarray(x), e[:2, :2].copy(), e[:2, 2].copy(), e[:2, 3].copy())


def _delayed(tf: np.ndarray, x: np.ndarray, t: np.ndarray, d: float) -> np.ndarray:
    """x(t - d), linearly interpolated on the fine grid, held at x(0) before the start."""
    return np.interp(t - d, tf, x, left=x[0])


# ============================================================================================
# public API
# ============================================================================================

def _check_number(name: str, v: Any, lo: float | None = None, hi: float | None = None,
                  lo_open: bool = False) -> float:
    if isinstance(v, bool) or not isinstance(v, (int, float, np.integer, np.floating)):
        raise ValueError(f"{name} must be a number, got {v!r}")
    x = float(v)
    if not math.isfinite(x):
        raise ValueError(f"{name} must be finite, got {v!r}")
    if lo is not None and (x < lo or (lo_open and x <= lo)):
        raise ValueError(f"{name} must be {'>' if lo_open else '>='} {lo}, got {v!r}")
    if hi is not None and x > hi:
        raise ValueError(f"{name} must be <= {hi}, got {v!r}")
    return x


def _check_int(name: str, v: Any, lo: int | None = None, hi: int | None = None) -> int:
    if isinstance(v, bool) or not isinstance(v, (int, np.integer)):
        raise ValueError(f"{name} must be an integer, got {v!r}")
    x = int(v)
    if lo is not None and x < lo:
        raise ValueError(f"{name} must be >= {lo}, got {v!r}")
    if hi is not None and x > hi:
        raise ValueError(f"{name} must be <= {hi}, got {v!r}")
    return x


@dataclass(frozen=True)
class SensorSpec:
    """What the bench's sensors are (and what a run's metadata states of them)."""

    sample_rate_hz: float = 100.0      # 10..1000
    encoder_res_deg: float = 0.01      # output encoder step [deg], 1e-6..1
    torque_noise: float = 150.0        # sd of the torque reading [N m], 0..1e4
    torque_lag_s: float = 0.01         # the torque amplifier's (Bessel) group delay [s], 0..0.5
    torque_adc_step: float = 5.0       # torque ADC step [N m], 0..1000
    load_noise: float = 80.0           # sd of the load-cell reading [N m], 0..1e4
    load_lag_s: float = 0.005          # load-cell amplifier time constant [s], 0..0.5
    load_adc_step: float = 5.0         # load-cell ADC step [N m], 0..1000
    motor_encoder_bits: int = 20       # motor encoder counts/rev = 2**bits, 8..32
    current_noise: float = 0.01        # sd of the current readings [A], 0..10

    _RANGES: ClassVar[dict[str, tuple[float, float]]] = {
        "sample_rate_hz": (10.0, 1000.0), "encoder_res_deg": (1e-6, 1.0),
        "torque_noise": (0.0, 1e4), "torque_lag_s": (0.0, 0.5), "torque_adc_step": (0.0, 1000.0),
        "load_noise": (0.0, 1e4), "load_lag_s": (0.0, 0.5), "load_adc_step": (0.0, 1000.0),
        "current_noise": (0.0, 10.0),
    }

    def __post_init__(self) -> None:
        for name, (lo, hi) in self._RANGES.items():
            object.__setattr__(self, name, _check_number(name, getattr(self, name), lo, hi))
        object.__setattr__(self, "motor_encoder_bits",
                           _check_int("motor_encoder_bits", self.motor_encoder_bits, 8, 32))

    def key(self) -> tuple:
        return tuple(getattr(self, n) for n in (*self._RANGES, "motor_encoder_bits"))


@dataclass
class RigRun:
    samples: pd.DataFrame
    meta: dict
    truth: pd.DataFrame
    params: dict


def _check_effects(effects: Any) -> dict[str, tuple[int, float]]:
    """{name: (form index, scale)} of the effects with a non-zero scale."""
    if effects is None:
        return {}
    if not isinstance(effects, dict):
        raise ValueError(f"effects must be a dict {{name: {{'form', 'scale'}}}}, got {effects!r}")
    out: dict[str, tuple[int, float]] = {}
    for name, spec in effects.items():
        if name not in EFFECT_FORMS:
            raise ValueError(f"effects: unknown effect {name!r}; known: {sorted(EFFECT_FORMS)}")
        if not isinstance(spec, dict) or set(spec) != {"form", "scale"}:
            raise ValueError(f"effects[{name!r}] must be {{'form': str, 'scale': float}}, "
                             f"got {spec!r}")
        form = spec["form"]
        if not isinstance(form, str) or form not in EFFECT_FORMS[name]:
            raise ValueError(f"effects[{name!r}]: unknown form {form!r}; "
                             f"known: {EFFECT_FORMS[name]}")
        scale = _check_number(f"effects[{name!r}] scale", spec["scale"], 0.0, None)
        if scale > SCALE_MAX:
            raise ValueError(f"effects[{name!r}] scale must be <= SCALE_MAX = {SCALE_MAX}, "
                             f"got {scale!r}")
        if scale > 0.0:
            out[name] = (EFFECT_FORMS[name].index(form), scale)
    return out


def _machine(seed: int, unstated: bool) -> dict[str, Any]:
    """The campaign's machine: design values with a small spread fixed by the seed."""
    rng = np.random.default_rng([seed, 0x5EED, 17])
    z = lambda: float(np.clip(rng.standard_normal(), -2.5, 2.5))  # noqa: E731
    m: dict[str, Any] = {}
    m["I"] = TABLE3["I"] * (1 + 0.01 * z())
    m["mr_x"] = TABLE3["mr_x"] * (1 + 0.03 * z())
    m["mr_y"] = TABLE3["mr_y"] * (1 + 0.03 * z())
    m["f_v"] = TABLE3["f_v"] * (1 + 0.01 * z())
    m["f_c"] = TABLE3["f_c"] * (1 + 0.01 * z())
    m["k1"] = K1 * (1 + 0.02 * z())
    m["c_h"] = CH_EFF * (1 + 0.02 * z())
    m["T_p"] = TP
    m["D"] = DAMP_T * (1 + 0.05 * z())
    m["k_t"] = [KT_NOM * (1 + 0.015 * z()) for _ in range(3)]
    m["J_d"] = 1.2e4 * (1 + 0.03 * z())
    m["k_s"] = 5.0e6 * (1 + 0.03 * z())
    m["gms_disp"] = [d * (1 + 0.05 * z()) for d in GMS_DISP]
    # unstated imperfections (drawn even when switched off, so the machine stays the same)
    asym = float(rng.uniform(0.02, 0.035)) * m["f_c"]
    rip_a = float(rng.uniform(25.0, 45.0))
    rip_ph = float(rng.uniform(0.0, 2 * math.pi))
    off = float(rng.uniform(40.0, 90.0)) * (1.0 if rng.uniform() < 0.5 else -1.0)
    m["unstated"] = {
        "asymmetric_friction": {"extra_coulomb_negative_nm": asym if unstated else 0.0},
        "gear_ripple": {"amplitude_nm": rip_a if unstated else 0.0, "phase_rad": rip_ph,
                        "cycles_per_rev": RIP_Z},
        "torque_offset": {"offset_nm": off if unstated else 0.0},
    }
    return m


def _param_vector(mach: dict, scheme: int, rpm: float | None, direction: int) -> np.ndarray:
    P = np.zeros(NP)
    P[P_I] = mach["I"]
    P[P_MRX] = mach["mr_x"]
    P[P_MRY] = mach["mr_y"]
    P[P_G] = G
    P[P_FV] = mach["f_v"]
    P[P_FC] = mach["f_c"]
    P[P_K1] = mach["k1"]
    P[P_CH] = mach["c_h"]
    P[P_TP] = mach["T_p"]
    P[P_D] = mach["D"]
    P[P_N] = REDUCTION
    j_in = 3 * J_ROTOR + J_STAGE1
    P[P_JIN] = j_in
    P[P_JU] = REDUCTION ** 2 * j_in
    P[P_KT1], P[P_KT2], P[P_KT3] = mach["k_t"]
    P[P_KTN] = KT_NOM
    P[P_TAUC] = 1.0e-3
    P[P_IMAX] = 8.0
    P[P_KPS] = 0.09
    P[P_KIS] = 1.35
    P[P_KPOS] = 4.0
    P[P_FCM] = 0.12
    P[P_FVM] = 1.5e-4
    P[P_WEPS] = 0.5
    for i in range(N_GMS):
        a = GMS_ALPHA[i]
        k = a * mach["f_c"] / mach["gms_disp"][i]
        P[P_GA0 + i] = a
        P[P_GK0 + i] = k
        P[P_GC0 + i] = 2 * GMS_ZETA * math.sqrt(k * mach["I"])
    P[P_GATT] = mach["f_c"] / GMS_TATT
    P[P_KS] = mach["k_s"]
    P[P_CS] = 1.5e4
    P[P_JD] = mach["J_d"]
    P[P_BD] = 1500.0
    P[P_TAUCD] = 4.0e-3
    P[P_KWD] = 3.0e5
    P[P_KTP] = 1.6e-6
    P[P_KTI] = 2.4e-6
    P[P_TDMAX] = 2.0e5
    P[P_SCHEME] = scheme
    P[P_DIR] = direction
    P[P_WREF] = 0.0 if rpm is None else rpm * 2 * math.pi / 60.0
    P[P_TLOAD] = T_RATED
    P[P_TF] = T_EXC
    a, b, q0 = _fourier_coeffs()
    P[P_FA0:P_FA0 + 5] = a
    P[P_FB0:P_FB0 + 5] = b
    P[P_FQ0] = q0
    un = mach["unstated"]
    P[P_USYM] = un["asymmetric_friction"]["extra_coulomb_negative_nm"]
    P[P_URA] = un["gear_ripple"]["amplitude_nm"]
    P[P_URPH] = un["gear_ripple"]["phase_rad"]
    P[P_CG] = 2.5e4
    P[P_RG] = 0.15
    P[P_TAMB] = 22.0
    P[P_CW] = 600.0
    P[P_RW] = 1.1
    P[P_RWA] = 0.8
    return P


def _phase(t: np.ndarray, scheme: int) -> np.ndarray:
    if scheme == 3:
        return np.full(t.shape, "excite", dtype=object)
    out = np.full(t.shape, "idle", dtype=object)
    if scheme == 1:
        out[(t >= 3.0) & (t < 33.0)] = "load"
        out[(t >= 33.0) & (t < 37.0)] = "hold"
        out[(t >= 37.0) & (t < 67.0)] = "unload"
        return out
    up = (t >= 3.0) & (t < 33.0)
    down = (t >= 37.0) & (t < 67.0)
    ramp_up = up & (((t - 3.0) % 2.5) < 0.5)
    ramp_dn = down & (((t - 37.0) % 2.5) < 0.5)
    out[up | down | ((t >= 33.0) & (t < 37.0))] = "hold"
    out[ramp_up] = "load"
    out[ramp_dn] = "unload"
    return out


_KERNEL_CACHE: OrderedDict[bytes, tuple] = OrderedDict()
_KERNEL_CACHE_SIZE = 8


def _run_kernel(P: np.ndarray, EF: np.ndarray, SC: np.ndarray, n_samp: int, m: int, h: float,
                y0: np.ndarray, th0: np.ndarray) -> tuple:
    """The simulation proper, memoised on its exact inputs (runs that differ only in their
    sensors or in sensor-only effects share it; the arrays are returned read-only)."""
    key = b"|".join([P.tobytes(), EF.tobytes(), SC.tobytes(), np.array([n_samp, m]).tobytes(),
                     np.array([h]).tobytes(), y0.tobytes(), th0.tobytes()])
    hit = _KERNEL_CACHE.get(key)
    if hit is not None:
        _KERNEL_CACHE.move_to_end(key)
        return hit
    stick = np.ones(N_GMS, dtype=np.int64)
    dirn = np.ones(N_GMS)
    out = _simulate(P, EF, SC, n_samp, m, h, y0, stick, dirn, th0, _TYP, JAC_EVERY)
    for a in out[:4]:
        a.flags.writeable = False
    _KERNEL_CACHE[key] = out
    while len(_KERNEL_CACHE) > _KERNEL_CACHE_SIZE:
        _KERNEL_CACHE.popitem(last=False)
    return out


def _quant(x: np.ndarray, step: float) -> np.ndarray:
    if step <= 0.0:
        return x
    return np.round(x / step) * step


def simulate_run(scheme: int, motor_speed_rpm: float | None, direction: int,
                 temp_joint_c: float, effects: dict[str, dict] | None = None, *,
                 sensors: SensorSpec | None = None, periods: int = 3, seed: int, run: int,
                 unstated: bool = True) -> RigRun:
    """Simulate one run of the bench (see the module docstring for the data sheet).

    ``unstated=False`` removes the bench's unstated imperfections (the nominal machine)."""
    if isinstance(scheme, bool) or not isinstance(scheme, (int, np.integer)) \
            or int(scheme) not in (1, 2, 3):
        raise ValueError(f"scheme must be 1, 2 or 3, got {scheme!r}")
    scheme = int(scheme)
    if scheme == 3:
        if motor_speed_rpm is not None:
            raise ValueError(f"motor_speed_rpm must be None for scheme 3, got {motor_speed_rpm!r}")
        rpm = None
    else:
        if motor_speed_rpm is None:
            raise ValueError("motor_speed_rpm is required for schemes 1 and 2 (0 < rpm <= 3000)")
        rpm = _check_number("motor_speed_rpm", motor_speed_rpm, 0.0, 3000.0, lo_open=True)
    if isinstance(direction, bool) or not isinstance(direction, (int, float, np.integer,
                                                                 np.floating)) \
            or direction not in (1, -1):
        raise ValueError(f"direction must be +1 or -1, got {direction!r}")
    direction = int(direction)
    temp = _check_number("temp_joint_c", temp_joint_c, 15.0, 60.0)
    eff = _check_effects(effects)
    if sensors is None:
        sensors = SensorSpec()
    if not isinstance(sensors, SensorSpec):
        raise ValueError(f"sensors must be a SensorSpec, got {sensors!r}")
    periods = _check_int("periods", periods, 1, 20)
    seed = _check_int("seed", seed, 0, None)
    run = _check_int("run", run, 0, None)
    if not isinstance(unstated, bool):
        raise ValueError(f"unstated must be True or False, got {unstated!r}")

    mach = _machine(seed, unstated)
    P = _param_vector(mach, scheme, rpm, direction)
    EF = np.full(N_EFFECTS, -1, dtype=np.int64)
    SC = np.zeros(N_EFFECTS)
    for name, (fi, sc) in eff.items():
        k = _EFFECT_ORDER.index(name)
        EF[k] = fi
        SC[k] = sc
    # the kernel sees only the effects that act on the machine
    EFk = EF.copy()
    SCk = SC.copy()
    for name in SENSOR_ONLY:
        k = _EFFECT_ORDER.index(name)
        EFk[k] = -1
        SCk[k] = 0.0

    rate = sensors.sample_rate_hz
    duration = SCHED["end"] if scheme in (1, 2) else periods * T_EXC
    n_samp = int(math.floor(duration * rate + 1e-9)) + 1
    h_max = H_MAX_RIPPLE if EFk[E_RIPPLE] == 1 else H_MAX
    m = int(math.ceil((1.0 / rate) / h_max - 1e-9))
    h = 1.0 / (rate * m)

    # initial state: at rest, q = u = 0, the GMS blocks holding the static load
    y0 = np.zeros(NS)
    stick = np.ones(N_GMS, dtype=np.int64)
    dirn = np.ones(N_GMS)
    dy = np.zeros(NS)
    aux = np.zeros(NA)
    _eval(0.0, y0, P, EFk, SCk, stick, dirn, temp, dy, aux)
    hold = P[P_I] * aux[A_QDD]
    for i in range(N_GMS):
        y0[Y_F0 + i] = GMS_ALPHA[i] * hold
    th0 = np.array([temp, temp + 1.5, temp + 1.5, temp + 1.5])

    S, A, TH, FINE, n_switch = _run_kernel(P, EFk, SCk, n_samp, m, h, y0, th0)

    t = np.arange(n_samp) / rate
    tf = np.arange(FINE.shape[0]) * h
    n = REDUCTION
    thg = TH[:, 0]

    # ---------------- truth ----------------
    truth = pd.DataFrame({
        "t": t, "q": S[:, Y_Q], "qd": S[:, Y_QD], "qdd": A[:, A_QDD], "u": S[:, Y_U],
        "ud": S[:, Y_W], "twist": S[:, Y_U] - S[:, Y_Q], "torque": A[:, A_T],
        "torque_load": A[:, A_TS], "torque_cmd": A[:, A_TSET], "torque_elastic": A[:, A_TE],
        "torque_hysteresis": A[:, A_HYS], "friction": A[:, A_FF], "gravity": A[:, A_G],
        "ripple_torque": A[:, A_TRIP], "disturbance": A[:, A_TDIST] + A[:, A_C0],
        "absorber_torque": A[:, A_TABS], "slide_level_pos": A[:, A_SPOS],
        "slide_level_neg": A[:, A_SNEG], "viscous_coef": A[:, A_FV],
        "twist_effective": A[:, A_DEFF], "q_ref": A[:, A_QREF],
        "w_m": S[:, Y_W] * n, "i_m1": S[:, Y_I1], "i_m2": S[:, Y_I2], "i_m3": S[:, Y_I3],
        "motor_torque": A[:, A_TAUM], "loader_angle": S[:, Y_THD], "loader_speed": S[:, Y_WD],
        "temp_joint": thg, "temp_m1": TH[:, 1], "temp_m2": TH[:, 2], "temp_m3": TH[:, 3],
        "gms_sticking": TH[:, 4], "hysteresis_state": S[:, Y_XH],
    })

    # ---------------- readings ----------------
    rng = np.random.default_rng([seed, run, 1])
    zt = rng.standard_normal(n_samp)
    zl = rng.standard_normal(n_samp)
    zi = rng.standard_normal((3, n_samp))
    zw = rng.standard_normal((3, n_samp))
    zth = rng.standard_normal((4, n_samp))
    zh = rng.standard_normal((3, n_samp))
    hyd_wander = rng.uniform(-0.004, 0.004)

    def eff_of(name: str) -> tuple[int, float]:
        k = _EFFECT_ORDER.index(name)
        return int(EF[k]), float(SC[k])

    # torque transducer: Bessel amplifier (stated lag), [unstated lag], offset, noise, ADC
    tq = _bessel2(FINE[:, 0], h, sensors.torque_lag_s)
    fdl, sdl = eff_of("time_delay")
    if fdl == 1:
        tq = _lowpass1(tq, h, sdl * DL_FILTER)
    if fdl == 0:
        tq_s = _delayed(tf, tq, t, sdl * DL_TORQUE)
    else:
        tq_s = tq[::m].copy()
    off = np.full(n_samp, mach["unstated"]["torque_offset"]["offset_nm"])
    fo, so = eff_of("torque_offset")
    if fo == 0:
        off += so * OFF_C
    elif fo == 1:
        off += so * OFF_RATE * t
    elif fo == 2:
        off += so * OFF_SET_A * (1.0 - np.exp(-t / OFF_SET_TAU))
    elif fo == 3:
        off += so * OFF_THERM * (thg - TF_REF)
    torque_r = _quant(tq_s + off + sensors.torque_noise * zt, sensors.torque_adc_step)

    # load cell
    ld = _lowpass1(np.ascontiguousarray(FINE[:, 1]), h, sensors.load_lag_s)[::m].copy()
    flc, slc = eff_of("loadcell_drift")
    if flc == 0:
        ld += slc * LC_RATE * t
    elif flc == 1:
        ld += slc * LC_A * (1.0 - np.exp(-t / LC_TAU))
    load_r = _quant(ld + sensors.load_noise * zl, sensors.load_adc_step)

    # output encoder
    if fdl == 2:
        qs = _delayed(tf, FINE[:, 2], t, sdl * DL_ENC)
    else:
        qs = FINE[::m, 2].copy()
    fe, se = eff_of("encoder_eccentricity")
    if fe == 0:
        qs = qs + se * ECC_E * np.sin(qs + ECC_PH)
    elif fe == 1:
        qs = qs + se * ECC_SCALE * qs
    res_q = math.radians(sensors.encoder_res_deg)
    q_r = _quant(qs, res_q)

    # motor encoder (motor 1), divided by N
    step_m = 2 * math.pi / 2 ** sensors.motor_encoder_bits
    u_r = _quant(S[:, Y_U] * n, step_m) / n

    cur = [_quant(S[:, Y_I1 + i] + sensors.current_noise * zi[i], 1e-3) for i in range(3)]
    spd = [_quant(S[:, Y_W] * n + 0.05 * zw[i], 1e-3) for i in range(3)]
    temps = [_quant(TH[:, i] + 0.05 * zth[i], 0.1) for i in range(4)]
    p_true = SHEAR / BORE_AREA * (1.0 + hyd_wander)
    f_true = p_true * BORE_AREA
    samples = pd.DataFrame({
        "t": t, "q": q_r, "u": u_r, "torsion": q_r - u_r, "torque": torque_r,
        "torque_load": load_r, "torque_cmd": A[:, A_TSET].copy(),
        "i_m1": cur[0], "i_m2": cur[1], "i_m3": cur[2],
        "w_m1": spd[0], "w_m2": spd[1], "w_m3": spd[2],
        "temp_m1": temps[1], "temp_m2": temps[2], "temp_m3": temps[3], "temp_joint": temps[0],
        "p_hyd": p_true + 5e3 * zh[0], "m_bend": f_true * LEVER + 150.0 * zh[1],
        "f_shear": f_true + 100.0 * zh[2],
        "phase": pd.Series(_phase(t, scheme), dtype=object),
    })
    truth["p_hyd"] = p_true
    truth["m_bend"] = f_true * LEVER
    truth["f_shear"] = f_true

    sens_meta = {
        "q": {"resolution": res_q, "noise_sd": 0.0, "lag_s": 0.0},
        "u": {"resolution": step_m / n, "noise_sd": 0.0, "lag_s": 0.0},
        "torque": {"resolution": sensors.torque_adc_step, "noise_sd": sensors.torque_noise,
                   "lag_s": sensors.torque_lag_s},
        "torque_load": {"resolution": sensors.load_adc_step, "noise_sd": sensors.load_noise,
                        "lag_s": sensors.load_lag_s},
        "torque_cmd": {"resolution": 0.0, "noise_sd": 0.0, "lag_s": 0.0},
        **{f"i_m{i}": {"resolution": 1e-3, "noise_sd": sensors.current_noise, "lag_s": 0.0}
           for i in (1, 2, 3)},
        **{f"w_m{i}": {"resolution": 1e-3, "noise_sd": 0.05, "lag_s": 0.0} for i in (1, 2, 3)},
        **{c: {"resolution": 0.1, "noise_sd": 0.05, "lag_s": 0.0}
           for c in ("temp_m1", "temp_m2", "temp_m3", "temp_joint")},
        "p_hyd": {"resolution": 0.0, "noise_sd": 5e3, "lag_s": 0.0},
        "m_bend": {"resolution": 0.0, "noise_sd": 150.0, "lag_s": 0.0},
        "f_shear": {"resolution": 0.0, "noise_sd": 100.0, "lag_s": 0.0},
    }
    minute = (seed * 7 + run * 3) % (24 * 60)
    meta = {
        "scheme": scheme, "motor_speed_rpm": rpm, "direction": direction,
        "reduction": REDUCTION, "rig": RIG_NAME, "source": "emulator",
        "sample_rate_hz": rate,
        "started_at": f"2026-03-{1 + run % 28:02d}T{minute // 60:02d}:{minute % 60:02d}:00Z",
        "notes": f"{RIG_NAME}: independent bench model, seed {seed}, run {run}",
        "shear_setpoint_n": SHEAR, "bend_setpoint_nm": SHEAR * LEVER,
        "sensors": sens_meta,
    }

    eff_params = {}
    for name, (fi, sc) in eff.items():
        eff_params[name] = {"form": EFFECT_FORMS[name][fi], "scale": sc,
                            "sensor_only": name in SENSOR_ONLY,
                            "out_of_vocabulary": name in OUT_OF_VOCABULARY}
    params = {
        "rig": RIG_NAME, "seed": seed, "run": run, "scheme": scheme,
        "motor_speed_rpm": rpm, "direction": direction, "temp_joint_c": temp,
        "periods": periods if scheme == 3 else None, "duration_s": float(t[-1]),
        "machine": {k: v for k, v in mach.items() if k != "unstated"} | {
            "N": REDUCTION, "J_u": float(P[P_JU]), "k_secant_120knm": T_RATED / (
                T_RATED / mach["k1"] + _hertz_g(T_RATED, mach["c_h"], TP)),
            "gms_alpha": list(GMS_ALPHA), "gms_k": [float(P[P_GK0 + i]) for i in range(N_GMS)],
            "m_bend": SHEAR * LEVER, "shear": SHEAR, "g": G},
        "unstated": mach["unstated"],
        "unstated_on": unstated,
        "effects": eff_params,
        "sensors": {k: getattr(sensors, k) for k in (*SensorSpec._RANGES,
                                                     "motor_encoder_bits")},
        "numerics": {"integrator": "ROS2 Rosenbrock-W", "h": h, "steps_per_sample": m,
                     "gms_switch_events": int(n_switch)},
        "fourier": {"a": P[P_FA0:P_FA0 + 5].tolist(), "b": P[P_FB0:P_FB0 + 5].tolist(),
                    "q0": float(P[P_FQ0]), "period_s": T_EXC},
    }
    return RigRun(samples=samples, meta=meta, truth=truth, params=params)
