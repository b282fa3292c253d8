"""Validation rig T: an independent physics model of the CFETR CMOR joint-4 test bench.

Written from the paper (../shared/seeds/cmor-sghmc-paper.txt, sections II-B, Table 3, Eq. 4,
Eq. 12, Tables 10-11) and ../shared/docs only, with its own modelling choices, so that a
sim-to-real diagnosis can be scored blind on runs it did not help to make. Nothing here is
shared with simulators/.

DATA SHEET (SI units; angles at the output are "output-referred": motor angle / N)
=================================================================================

Machine (drawn once per campaign from `seed`; Table 3 values with a small spread)
-------------------------------------------------------------------------------
Output body (hub), Eq. 4 of the paper plus the load:
    I*q'' = T - tau_L - g*(mr_x*sin q + mr_y*cos q) - F_fric
with I ~ N(6685.166, 25) kg m^2, mr_x ~ N(20.779, 0.5) kg m, mr_y ~ N(-34.543, 1.0) kg m,
f_v ~ N(8683.272, 6) N m s/rad, f_c ~ N(2352.660, 6) N m, each clipped to Table 3's 95 %
interval; g = 9.81 m/s^2. In steady sliding (|q'| > v_win) and with no effect,
F_fric = f_v*q' + f_c*sgn(q'), i.e. exactly Eq. 4.

Friction: a Karnopp stick/slip switch (not LuGre, Dahl or any bristle model).
    |q'| >  v_win: F = sgn(q')*C(sgn q') + V(sgn q')*q'        (slip)
    |q'| <= v_win: with F_ext the sum of all other torques on the hub,
        F = F_ext + I*q'/tau_s, clipped to [-C(-1), +C(+1)]   (stick: q' decays to 0)
        F = +C(+1) if F_ext > C(+1);  F = -C(-1) if F_ext < -C(-1)     (break-away)
    v_win = 2e-5 rad/s (0.7 % of the 300 r/min output speed), tau_s = 5 ms.
    Nominal C = f_c (break-away level = Coulomb level), V = f_v; effects modify C, V.

Transmission (three motors -> shared first stage -> main stage -> output):
    motors k = 1..3: rotor J_m = 1.2e-3 kg m^2 (+-2 %), k_t = 1.8 N m/A, i_max = 6 A each
        (current loop taken as ideal within its limit: i_k = clip(tau_k/k_t, +-i_max)),
        motor-side friction 0.08*tanh(w/0.5) + 1e-4*w N m, winding R = 0.9 Ohm at 20 C
        (+0.393 %/K); pinion -> first stage n1 = 10, mesh stiffness 150 N m/rad (+-3 %) at
        the first-stage shaft per motor, mesh damping 4e-3 s x stiffness;
    first-stage shaft: J_s = 0.02 kg m^2, mesh loss 3 % of |sum of mesh torques|
        (smooth sign of its speed) + 2e4 N m s/rad (output-referred) viscous drag;
    main stage n2 = 1100 (N = n1*n2 = 11000) with a cubic-hardening spring and mesh damping
        proportional to the tangent stiffness:
        T = k0*g(a) + k3*g(a)^3 + beta_d*k_tan*a' + T_hyst,   a = phi/n2 - q  (main twist)
        k0 = 1.2e7 N m/rad (+-3 %), k3 = h*k0/(0.01 rad)^2 with h ~ 0.06 (6 % stiffer at
        0.01 rad, i.e. near rated torque), beta_d = 8e-3 s, g(a) = a (no backlash),
        T_hyst = 0 nominally.
    The twist u - q (u = mean of the three motor angles / N) is the main twist plus the mean
    mesh deflection; the effective linear stiffness is k_eff = 1/(1/k0 + 1/(3*k_mesh*n2^2))
    ~ 1.17e7 N m/rad (params["machine"]["stiffness"]): T ~ k_eff*(u - q), up to ~8 % stiffer
    near rated torque (the cubic term); about 0.55 deg of twist at 120 kN m.

Drive control (load sharing): a PI speed loop on the mean motor speed (Kp = 0.25 N m s/rad,
    Ki = 3.0 N m/rad, motor side, with conditional-integration anti-windup) gives a total
    torque demand tau_d; motor k gets s_k*tau_d + b_k*max(0, 1 - |tau_d|/6 N m)
    - c_x*(w_k - w_mean): sharing fractions s_k ~ 1/3 (+-1 %), anti-backlash bias
    b = (+0.8, -0.4, -0.4) N m fading out at 6 N m of demand, cross-coupling damping
    c_x = 0.06 N m s/rad. Scheme 3 adds a position loop on the mean motor angle
    (w_ref = q_ref' + 6/s*(q_ref - u)) and an inertia feedforward.

Loading device: an electric dynamometer (servo motor + reducer) on a torque loop closed on
    its load cell: tau_L' = (tau_cmd + 1.0*e + 8/s*int(e) - tau_L)/10 ms, e = tau_cmd - tau_L;
    tau_cmd >= 0 is the paper's positive loading, whatever the direction of motion (with
    direction -1 the load overhauls the joint). Its rotor inertia is behind the load cell
    and compensated by the loop. Its torque ripple (reducer mesh, cogging, current loop) is
    added to tau_L unregulated: Gaussian noise band-limited to 0.3-20 Hz, 50 N m rms, drawn
    per run from (seed, run), faded in over 0.5 s; the load cell measures it (so the torque
    balance closes) and it excites the resonances broadband. A hydraulic cylinder (bore area 0.0314 m^2, arm 0.55 m)
    holds a constant pressure ~ 2.9 MPa (+-2 %): shear ~ 91 kN, bending ~ 50 kN m.

Thermal: a two-node gearbox (oil/mesh node C = 3e4 J/K, housing C = 3e5 J/K, 60 W/K between
    them, 25 W/K housing-ambient, ambient ~ N(20, 1.5) C) heated by output friction, mesh
    damping, first-stage loss and half the motor-side friction; windings C = 800 J/K,
    1.5 W/K to the housing, heated by i^2*R(T). The run starts with oil and housing at
    temp_joint_c and windings at temp_joint_c + N(0, 0.5) C (per run). temp_joint is the oil.

Schemes (section II-B)
----------------------
1: motor speed ramps to +-motor_speed_rpm in 1 s (cosine), idle to 4 s, load 0 -> 120 kN m
   by 34 s, hold to 36 s, unload to 0 by 66 s, idle to 70 s (70 s).
2: idle to 4 s, twelve 10 kN m steps (1 s ramp + 2 s hold each) up to 120 kN m, unload in
   12 s, idle 4 s (56 s).
3: Eq. 12, fifth order, base period 12 s, `periods` periods, at rest at t = 0 (q = q' = q''
   = 0), peak speed 0.0215 rad/s (< 0.9 x the 3000 r/min limit); coefficients (rad/s)
   a = (0.00291622, -0.0036174, 0.00087003, 0.00479385, -0.0049627),
   b = (0.00227942, -7.46547e-05, -0.00658257, 0.00316384, 0.000992447), optimised offline
   for the smallest condition number of the column-normalised Eq. 4 regressor; a_1 and b_1
   are recomputed so that q'(0) = q''(0) = 0 exactly. direction -1 mirrors it. No load.

Integrator: Bogacki-Shampine 3(2) with FSAL, per-state absolute error control (max norm),
step floor 1e-6 s (accepted regardless of error, so stick-slip cannot stall it), ceiling
20 ms, and cubic Hermite dense output on an internal grid of >= 1 kHz, from which every
sensor (lags, filters, velocity differencing) is computed. Numba (@njit(cache=True)).

Sensors (stated in meta["sensors"]: per channel resolution, noise_sd, lag_s)
---------------------------------------------------------------------------
q      output encoder, rounded to encoder_res_deg (default 0.01 deg), no noise.
qd     the PLC's output velocity: (q_enc(t) - q_enc(t - W))/W, W = qd_window_s (0.1 s);
       stated resolution res/W and lag W/2.
u      mean of three motor encoders (motor_encoder_counts per rev, default 16384) / N;
       stated resolution 2*pi/(counts*N)/3.  ud: mean drive speed / N.  torsion = q - u.
torque transducer on the output shaft: T delayed by torque_lag_s (stated pure lag), noise
       torque_noise (sd, default 150 N m), ADC step torque_adc_step (5 N m).
torque_load load cell: tau_L + noise load_noise (100 N m), step load_adc_step (5 N m).
torque_cmd set point. i_m1..3 [A], w_m1..3 [rad/s motor side], temp_m1..3, temp_joint
       (0.1 C steps, 0.03 C noise), p_hyd, m_bend, f_shear, phase.

Unstated imperfections (params["unstated"]; not in meta)
-------------------------------------------------------
- torque zero offset ~ N(0, 40) N m                                         (torque_offset)
- bending-moment cross-talk into the torque gauge: kappa*m_bend, kappa ~ 0.0015 (+-30 %),
  ~ 75 N m                                                                  (torque_offset)
- torque-gauge thermal zero drift ~ 1.5 N m/K (+-30 %) x (T_oil - 25 C)     (torque_offset)
- torque amplifier first-order low-pass, tau ~ 4 ms (2..6 ms), not the stated lag (time_delay)
- output-encoder interpolation error 0.0008 deg (+-20 %) x sin(2048*q + phase)
  (2048-line grating; no vocabulary name)

Effects: effects={name: {"form": form, "scale": s}}, 0 <= s <= SCALE_MAX (= 8)
-----------------------------------------------------------------------------
Sizes at scale s (s = 1 is "clearly visible but modest"); theta = oil temperature [C],
theta_ref = 35 C, T_r = 120 kN m, sigma = direction of sliding, z = 96 mesh cycles/rev.
stribeck (added to C; break-away level C(0) = f_c + dS), dS = 400*s N m, v_s = 5e-3 rad/s
    (the 300 r/min output speed is 0.57 v_s: +230..300 N m there, ~0..60 N m at 3000 r/min;
    beyond s ~ 1.5 the falling curve out-runs the damping and 300 r/min runs stick-slip):
    exponential dS*exp(-|v|/v_s); gaussian dS*exp(-(v/v_s)^2); lorentzian dS/(1+(v/v_s)^2);
    hyperbolic dS*v_s/(v_s+|v|)
load_dependent_friction (T = transmitted torque):
    coulomb_linear C += 0.003*s*|T|; coulomb_viscous C, V *= 1 + 0.12*s*|T|/T_r;
    power_flow C += s*|T|*(0.004 if T*sigma > 0 (driving) else 0.0015 (back-driven));
    coulomb_quadratic C += 0.003*s*T^2/T_r
temperature_friction:
    viscous_exponential V *= exp(min(0.03*s*(theta_ref - theta), 2.3));
    coulomb_additive C += 10*s*(theta_ref - theta) N m (C >= 0.1 f_c);
    coulomb_viscous_linear C, V *= max(0.1, 1 + 0.004*s*(theta_ref - theta))
gear_ripple (phases 0.4, 1.9 rad):
    output_torque: torque on the hub 250*s*(sin(zq+0.4) + 0.35 sin(2zq+1.9)) N m;
    output_kinematic: transmission error in the main twist 2.5e-5*s*(sin(zq+0.4)
        + 0.3 sin(2zq+1.9)) rad (~300 N m through k0);
    input_shaft_kinematic: 2.5e-5*s*(sin(2*phi+0.4) + 0.3 sin(4*phi+1.9)) rad, phi = the
        main stage's input (wave-generator) angle = motor angle / 10: 2 and 4 cycles per
        input revolution;
    load_modulated: hub torque 250*s*(0.3 + 0.7|T|/T_r)*sin(zq+0.4)
torque_offset (torque reading only): constant 250*s; linear_drift 300*s*t/60 s;
    warmup_drift 300*s*(1 - exp(-t/20 s)); random_walk 250*s*W(t/60 s) (W a standard
    Wiener process drawn from (seed, run))
time_delay (readings only): torque_pure extra pure lag 10*s ms on torque; torque_first_order
    extra first-order lag 10*s ms on torque; position_pure 1*s ms on q (and qd, torsion);
    motor_pure 1*s ms on u, ud, w_m* (and torsion)
hysteresis (added to T, on the main twist a): bouc_wen_n1 k_h*x, x' = a' - 2500|a'|x -
    2500 a'|x|, k_h = 1.5e6*s (loop +-300*s N m); bouc_wen_n2 x' = a' - 1.5e7|a'||x|x -
    1e7 a' x^2, k_h = 1.5e6*s; iwan: three play elements r = (0.6, 1.2, 2.4)e-4 rad with
    weights 100*s/r_i (+-300*s N m, rate independent); maxwell: k_m*y, y' = a' - y/1.5 s,
    k_m = 6e5*s (rate dependent, +-300*s N m at the scheme-1 loading rate)
backlash (dead zone in the main twist, half gap b = 2.5e-5*s rad ~ 300*s N m):
    sharp g = a -+ b outside, 0 inside; smooth_tanh g = a - b*tanh(a/b);
    smooth_quadratic g = a|a|/(4b) for |a| < 2b, a -+ b outside
asymmetric_friction: coulomb C += 200*s*sigma; viscous V *= (1+0.8*s)^sigma;
    coulomb_viscous C += 150*s*sigma and V *= (1+0.4*s)^sigma
periodic_disturbance (torque on the hub): sinusoid 300*s*sin(2pi*0.8t + 0.3);
    two_tone 200*s*(sin(2pi*0.35t) + sin(2pi*1.3t + 1)); square 300*s*tanh(4 sin(2pi t/6))
position_stiffness (k0 -> k0*(1 + m(q))): sinusoidal m = 0.004*s*cos(3q + 0.7);
    linear m = 0.004*s*q/rad; segment_joints m = -0.004*s*exp(-(d/0.08 rad)^2), d the
    distance of q to the nearest multiple of pi/3 (six ring segments)
sensor_drift (readings only): load_cell_linear torque_load += 300*s*t/60 s;
    encoder_linear q += 3e-5*s*t/60 s rad; load_cell_warmup torque_load += 300*s*(1-exp(-t/25 s))
second_resonance: an appendage of inertia I2 = I*mu(s), mu(s) = 0.25s/(1+0.25s), split off
    the output body (the hub keeps I - I2, so Eq. 4 holds at low frequency), 1 % damping,
    excited by the motion and the dynamometer's ripple:
    link_mode: spring tuned to 9 Hz, load on the hub;
    loading_flange: spring tuned to 12 Hz, a share min(1, mu(s)/mu(1)) of the load acts on
        the appendage (all of it from s = 1);
    sensor_on_link: spring of fixed stiffness I*mu(1)*(2pi*7 Hz)^2 (f2 = 7 Hz at s = 1,
        higher below, at most 40 Hz), load on the hub, the output encoder on the appendage.

Truth (RigRun.truth, on the sample times)
----------------------------------------
t; twist = u - q [rad] (u the mean motor angle / N, true); torque = T [N m] (true transmitted
torque); q, qd, qdd (hub); u; torque_load (tau_L with its ripple), torque_cmd; friction (hub
friction torque), gravity, disturbance (hub torques of gear_ripple/periodic_disturbance);
balance_residual = T - tau_L - Eq. 4 with the campaign's values (sgn = 0 inside v_win): 0 to
rounding in nominal sliding, the effect's share of the torque balance otherwise; temp_joint
(oil); i_m1..3; q_link (appendage angle, second_resonance only).
"""

from __future__ import annotations

import copy
import math
from dataclasses import dataclass, fields
from functools import lru_cache
from numbers import Integral, Real
from typing import Any

import numpy as np
import pandas as pd
from numba import njit

RIG_NAME = "rig_t"
REDUCTION = 11000.0
SEED_IS_CAMPAIGN = True
SCALE_MAX = 8.0

N1 = 10.0
"""Pinion -> first-stage gear ratio."""
N2 = REDUCTION / N1
"""Main-stage ratio (first-stage shaft -> output)."""
T_RATED = 120e3
"""Rated output torque [N m] (Table 10; scheme 1-2 maximum load)."""
THETA_REF = 35.0
"""Oil temperature [C] at which the friction is Table 3's (temperature effects)."""
MESH_Z = 96.0
"""Output mesh cycles per output revolution (gear_ripple on the output angle)."""
RES2_MU = 0.25
RES2_ZETA = 0.01
RES2_FMAX = 40.0
"""second_resonance: appendage inertia fraction I2/I = RES2_MU*s/(1 + RES2_MU*s), its damping
ratio, and the highest appendage frequency [Hz] (sensor_on_link at very small scales)."""
DYN_RIPPLE_RMS = 50.0
DYN_RIPPLE_BAND = (0.3, 20.0)
DYN_RIPPLE_RATE = 200.0
"""The dynamometer's torque ripple (its reducer mesh, cogging and current loop): Gaussian
noise band-limited to DYN_RIPPLE_BAND [Hz], DYN_RIPPLE_RMS [N m] rms, drawn per run, faded in
over the first 0.5 s, knots at DYN_RIPPLE_RATE [Hz] joined by a Catmull-Rom spline."""

EFFECT_FORMS: dict[str, tuple[str, ...]] = {
    "stribeck": ("exponential", "gaussian", "lorentzian", "hyperbolic"),
    "load_dependent_friction": ("coulomb_linear", "coulomb_viscous", "power_flow",
                                "coulomb_quadratic"),
    "temperature_friction": ("viscous_exponential", "coulomb_additive", "coulomb_viscous_linear"),
    "gear_ripple": ("output_torque", "output_kinematic", "input_shaft_kinematic",
                    "load_modulated"),
    "torque_offset": ("constant", "linear_drift", "warmup_drift", "random_walk"),
    "time_delay": ("torque_pure", "torque_first_order", "position_pure", "motor_pure"),
    "hysteresis": ("bouc_wen_n1", "bouc_wen_n2", "iwan", "maxwell"),
    "backlash": ("sharp", "smooth_tanh", "smooth_quadratic"),
    "asymmetric_friction": ("coulomb", "viscous", "coulomb_viscous"),
    "periodic_disturbance": ("sinusoid", "two_tone", "square"),
    "position_stiffness": ("sinusoidal", "linear", "segment_joints"),
    "sensor_drift": ("load_cell_linear", "encoder_linear", "load_cell_warmup"),
    "second_resonance": ("link_mode", "loading_flange", "sensor_on_link"),
}
"""Effect name -> the forms this rig makes of it (see the module docstring for each size)."""

OUT_OF_VOCABULARY = ("periodic_disturbance", "position_stiffness", "sensor_drift",
                     "second_resonance")

UNSTATED_VOCABULARY: dict[str, str] = {
    "torque_offset": "torque-gauge zero offset (~N(0, 40) N m), bending-moment cross-talk "
                     "(~0.15 % of m_bend, ~75 N m) and thermal zero drift (~1.5 N m/K about "
                     "25 C), none stated in the metadata",
    "time_delay": "the torque amplifier's first-order low-pass (~4 ms) on the torque "
                  "reading, on top of the stated pure lag",
}

READING_EFFECTS = ("torque_offset", "time_delay", "sensor_drift")
"""Effects that act on readings only: the true physics (RigRun.truth) is untouched."""

_FAMILIES = tuple(EFFECT_FORMS)
(F_STRIBECK, F_LOADF, F_TEMPF, F_RIPPLE, F_TOFF, F_DELAY, F_HYST, F_BACKLASH, F_ASYM,
 F_PERIODIC, F_POSSTIFF, F_DRIFT, F_RES2) = range(13)

# --- state, auxiliary-output and parameter indices (numba reads them as constants) ----------
(Y_Q, Y_V, Y_A, Y_WP, Y_E1, Y_E2, Y_E3, Y_W1, Y_W2, Y_W3, Y_SI, Y_TL, Y_ZL, Y_TOIL, Y_TH,
 Y_TM1, Y_TM2, Y_TM3, Y_XH, Y_P1, Y_P2, Y_P3, Y_R2, Y_V2) = range(24)
NY = 24

(X_T, X_F, X_QDD, X_G, X_DIST, X_TLHUB, X_I1, X_I2, X_I3, X_TAUD, X_TCMD, X_WREF, X_TK,
 X_PG, X_TEL, X_QREF, X_TL) = range(17)
NX = 17

(P_IHUB, P_MRX, P_MRY, P_FV, P_FC, P_GRAV, P_K0, P_K3, P_BD, P_KM1, P_KM2, P_KM3, P_BM,
 P_J1, P_J2, P_J3, P_JP, P_ETA, P_CP, P_EPSW, P_N, P_N2, P_KT, P_IMAX, P_R20, P_ALCU,
 P_FCM, P_FVM, P_WEPS, P_KP, P_KI, P_KPOS, P_CX, P_JFF, P_S1, P_S2, P_S3, P_B1, P_B2, P_B3,
 P_BFADE, P_TDYN, P_KPL, P_KIL, P_COIL, P_CH, P_GOH, P_GHA, P_TAMB, P_CM, P_GM, P_FMG,
 P_VWIN, P_TAUS, P_SCHEME, P_DIR, P_WCMD, P_TRAMP, P_WF, P_Q0) = range(60)
NP = 60

FOURIER_PERIOD_S = 12.0
_FOURIER_A_TAIL = (-0.0036174, 0.00087003, 0.00479385, -0.0049627)
_FOURIER_B_TAIL = (-7.46547e-05, -0.00658257, 0.00316384, 0.000992447)


def fourier_coefficients() -> tuple[np.ndarray, np.ndarray]:
    """Eq. 12 coefficients (a_l, b_l) [rad/s], l = 1..5, with a_1 and b_1 set so that the
    trajectory starts at rest: q'(0) = sum a_l = 0 and q''(0) = w_f*sum l*b_l = 0."""
    a = np.array((0.0,) + _FOURIER_A_TAIL)
    b = np.array((0.0,) + _FOURIER_B_TAIL)
    a[0] = -a[1:].sum()
    b[0] = -(np.arange(2, 6) * b[1:]).sum()
    return a, b


# =============================================================================================
# the model (numba)
# =============================================================================================

@njit(cache=True)
def _ramp(t: float, tr: float) -> float:
    if t <= 0.0:
        return 0.0
    if t >= tr:
        return 1.0
    return 0.5 - 0.5 * math.cos(math.pi * t / tr)


@njit(cache=True)
def _ripple(t, DN):
    """The dynamometer's torque ripple at t: a Catmull-Rom spline through knots DN[1:] at
    DYN_RIPPLE_RATE (DN[0] repeats the first knot), so it is smooth (C1) for the solver."""
    s = t * DYN_RIPPLE_RATE
    i = int(math.floor(s))
    if i < 0:
        i = 0
    nk = DN.size - 3
    if i > nk - 1:
        i = nk - 1
    u = s - i
    p0 = DN[i]
    p1 = DN[i + 1]
    p2 = DN[i + 2]
    p3 = DN[i + 3]
    return 0.5 * (2.0 * p1 + (p2 - p0) * u + (2.0 * p0 - 5.0 * p1 + 4.0 * p2 - p3) * u * u
                  + (3.0 * p1 - p0 - 3.0 * p2 + p3) * u * u * u)


@njit(cache=True)
def _levels(sig, av, T, theta, P, EC, EP):
    """Coulomb level C (incl. Stribeck and load terms) and viscous coefficient V of the
    output friction for sliding direction `sig` at speed |v| = av."""
    fc = P[P_FC]
    fv = P[P_FV]
    c = EC[F_TEMPF]
    if c == 1:
        fv *= math.exp(min(EP[F_TEMPF, 0] * (EP[F_TEMPF, 1] - theta), EP[F_TEMPF, 2]))
    elif c == 2:
        fc = max(0.1 * fc, fc + EP[F_TEMPF, 0] * (EP[F_TEMPF, 1] - theta))
    elif c == 3:
        f = max(0.1, 1.0 + EP[F_TEMPF, 0] * (EP[F_TEMPF, 1] - theta))
        fc *= f
        fv *= f
    c = EC[F_ASYM]
    if c == 1 or c == 3:
        fc = max(0.05 * P[P_FC], fc + sig * EP[F_ASYM, 0])
    if c == 2 or c == 3:
        if sig > 0:
            fv *= EP[F_ASYM, 1]
        else:
            fv /= EP[F_ASYM, 1]
    c = EC[F_LOADF]
    aT = abs(T)
    if c == 1:
        fc += EP[F_LOADF, 0] * aT
    elif c == 2:
        f = 1.0 + EP[F_LOADF, 0] * aT / T_RATED
        fc *= f
        fv *= f
    elif c == 3:
        if T * sig > 0.0:
            fc += EP[F_LOADF, 0] * aT
        else:
            fc += EP[F_LOADF, 1] * aT
    elif c == 4:
        fc += EP[F_LOADF, 0] * T * T / T_RATED
    c = EC[F_STRIBECK]
    if c != 0:
        ds = EP[F_STRIBECK, 0]
        x = av / EP[F_STRIBECK, 1]
        if c == 1:
            fc += ds * math.exp(-x)
        elif c == 2:
            fc += ds * math.exp(-x * x)
        elif c == 3:
            fc += ds / (1.0 + x * x)
        else:
            fc += ds / (1.0 + x)
    return fc, fv


@njit(cache=True)
def _rhs(t, y, P, EC, EP, FA, FB, LT, LV, DN, dy, aux):
    """State derivative dy and the observed quantities aux at (t, y)."""
    N = P[P_N]
    n2 = P[P_N2]
    q = y[Y_Q]
    v = y[Y_V]
    a = y[Y_A]
    wp = y[Y_WP]
    w1 = y[Y_W1]
    w2 = y[Y_W2]
    w3 = y[Y_W3]
    phio = q + a
    ubar = phio + (y[Y_E1] + y[Y_E2] + y[Y_E3]) / 3.0
    wbar = (w1 + w2 + w3) / 3.0

    # --- references ------------------------------------------------------------------------
    qddr = 0.0
    qr = 0.0
    if P[P_SCHEME] == 3.0:
        wf = P[P_WF]
        qr = P[P_Q0]
        qdr = 0.0
        for l in range(5):
            lw = wf * (l + 1)
            s_ = math.sin(lw * t)
            c_ = math.cos(lw * t)
            qr += FA[l] / lw * s_ - FB[l] / lw * c_
            qdr += FA[l] * c_ + FB[l] * s_
            qddr += -FA[l] * lw * s_ + FB[l] * lw * c_
        d = P[P_DIR]
        qr *= d
        qdr *= d
        qddr *= d
        wref = qdr + P[P_KPOS] * (qr - ubar)
        tcmd = 0.0
    else:
        wref = P[P_DIR] * P[P_WCMD] * _ramp(t, P[P_TRAMP])
        tcmd = np.interp(t, LT, LV)

    # --- main stage: kinematic error, backlash, position stiffness, hysteresis --------------
    ad = wp - v
    ek = 0.0
    ekd = 0.0
    c = EC[F_RIPPLE]
    if c == 2:
        E = EP[F_RIPPLE, 0]
        z = EP[F_RIPPLE, 1]
        x1 = z * q + EP[F_RIPPLE, 2]
        x2 = 2.0 * z * q + EP[F_RIPPLE, 3]
        ek = E * (math.sin(x1) + 0.3 * math.sin(x2))
        ekd = E * z * (math.cos(x1) + 0.6 * math.cos(x2)) * v
    elif c == 3:
        E = EP[F_RIPPLE, 0]
        phi = n2 * phio
        x1 = 2.0 * phi + EP[F_RIPPLE, 2]
        x2 = 4.0 * phi + EP[F_RIPPLE, 3]
        ek = E * (math.sin(x1) + 0.3 * math.sin(x2))
        ekd = E * (2.0 * math.cos(x1) + 1.2 * math.cos(x2)) * n2 * wp
    ae = a - ek
    aed = ad - ekd

    g = ae
    gp = 1.0
    c = EC[F_BACKLASH]
    if c != 0:
        b = EP[F_BACKLASH, 0]
        if c == 1:
            if ae > b:
                g = ae - b
            elif ae < -b:
                g = ae + b
            else:
                g = 0.0
                gp = 0.0
        elif c == 2:
            th = math.tanh(ae / b)
            g = ae - b * th
            gp = th * th
        else:
            aa = abs(ae)
            if aa >= 2.0 * b:
                g = ae - b if ae > 0 else ae + b
            else:
                g = ae * aa / (4.0 * b)
                gp = aa / (2.0 * b)

    k0 = P[P_K0]
    c = EC[F_POSSTIFF]
    if c == 1:
        k0 *= 1.0 + EP[F_POSSTIFF, 0] * math.cos(3.0 * q + 0.7)
    elif c == 2:
        k0 *= 1.0 + EP[F_POSSTIFF, 0] * q
    elif c == 3:
        seg = math.pi / 3.0
        dq = q - seg * math.floor(q / seg + 0.5)
        k0 *= 1.0 - EP[F_POSSTIFF, 0] * math.exp(-(dq / 0.08) ** 2)
    k3 = P[P_K3]
    tel = k0 * g + k3 * g * g * g
    ktan = (k0 + 3.0 * k3 * g * g) * gp
    tdamp = P[P_BD] * ktan * aed

    th_ = 0.0
    dxh = 0.0
    c = EC[F_HYST]
    if c == 1:
        x = y[Y_XH]
        th_ = EP[F_HYST, 0] * x
        dxh = ad - EP[F_HYST, 1] * abs(ad) * x - EP[F_HYST, 2] * ad * abs(x)
    elif c == 2:
        x = y[Y_XH]
        th_ = EP[F_HYST, 0] * x
        dxh = ad - EP[F_HYST, 1] * abs(ad) * abs(x) * x - EP[F_HYST, 2] * ad * x * x
    elif c == 3:
        for i in range(3):
            r = EP[F_HYST, 1 + i]
            p = min(max(y[Y_P1 + i], a - r), a + r)
            th_ += EP[F_HYST, 4 + i] * (a - p)
    elif c == 4:
        x = y[Y_XH]
        th_ = EP[F_HYST, 0] * x
        dxh = ad - x / EP[F_HYST, 1]
    T = tel + tdamp + th_

    # --- output hub ------------------------------------------------------------------------
    G = P[P_GRAV] * (P[P_MRX] * math.sin(q) + P[P_MRY] * math.cos(q))
    dist = 0.0
    c = EC[F_RIPPLE]
    if c == 1:
        z = EP[F_RIPPLE, 1]
        dist += EP[F_RIPPLE, 0] * (math.sin(z * q + EP[F_RIPPLE, 2])
                                   + 0.35 * math.sin(2.0 * z * q + EP[F_RIPPLE, 3]))
    elif c == 4:
        z = EP[F_RIPPLE, 1]
        dist += EP[F_RIPPLE, 0] * (0.3 + 0.7 * abs(T) / T_RATED) * math.sin(z * q + EP[F_RIPPLE, 2])
    c = EC[F_PERIODIC]
    if c == 1:
        dist += EP[F_PERIODIC, 0] * math.sin(2.0 * math.pi * 0.8 * t + 0.3)
    elif c == 2:
        dist += EP[F_PERIODIC, 0] * (math.sin(2.0 * math.pi * 0.35 * t)
                                     + math.sin(2.0 * math.pi * 1.3 * t + 1.0))
    elif c == 3:
        dist += EP[F_PERIODIC, 0] * math.tanh(4.0 * math.sin(2.0 * math.pi * t / 6.0))

    tL = y[Y_TL]
    tL += _ripple(t, DN)
    tl_hub = tL
    app = 0.0
    c = EC[F_RES2]
    if c != 0:
        r2 = y[Y_R2]
        v2 = y[Y_V2]
        app = EP[F_RES2, 1] * r2 + EP[F_RES2, 2] * (v2 - v)
        tl_app = EP[F_RES2, 3] * tL
        tl_hub = tL - tl_app
        dy[Y_R2] = v2 - v
        dy[Y_V2] = (-app - tl_app) / EP[F_RES2, 0]
    else:
        dy[Y_R2] = 0.0
        dy[Y_V2] = 0.0

    fext = T - tl_hub - G - dist + app
    ihub = P[P_IHUB]
    theta = y[Y_TOIL]
    if abs(v) > P[P_VWIN]:
        sig = 1.0 if v > 0.0 else -1.0
        C, V = _levels(sig, abs(v), T, theta, P, EC, EP)
        F = sig * C + V * v
    else:
        cpos, _v1 = _levels(1.0, 0.0, T, theta, P, EC, EP)
        cneg, _v2 = _levels(-1.0, 0.0, T, theta, P, EC, EP)
        if fext > cpos:
            F = cpos
        elif fext < -cneg:
            F = -cneg
        else:
            F = min(max(fext + ihub * v / P[P_TAUS], -cneg), cpos)
    acc = (fext - F) / ihub
    dy[Y_Q] = v
    dy[Y_V] = acc

    # --- first stage and motors ------------------------------------------------------------
    bm = P[P_BM]
    t1 = P[P_KM1] * (y[Y_E1] + bm * (w1 - wp))
    t2 = P[P_KM2] * (y[Y_E2] + bm * (w2 - wp))
    t3 = P[P_KM3] * (y[Y_E3] + bm * (w3 - wp))
    tk = t1 + t2 + t3
    fp = P[P_ETA] * abs(tk) * math.tanh(wp / P[P_EPSW]) + P[P_CP] * wp
    dy[Y_WP] = (tk - T - fp) / P[P_JP]
    dy[Y_A] = ad
    dy[Y_E1] = w1 - wp
    dy[Y_E2] = w2 - wp
    dy[Y_E3] = w3 - wp

    ew = wref - wbar
    taud = N * (P[P_KP] * ew + P[P_KI] * y[Y_SI]) + P[P_JFF] * N * qddr
    fade = max(0.0, 1.0 - abs(taud) / P[P_BFADE])
    kt = P[P_KT]
    imax = P[P_IMAX]
    cx = P[P_CX] * N
    tc1 = P[P_S1] * taud + P[P_B1] * fade - cx * (w1 - wbar)
    tc2 = P[P_S2] * taud + P[P_B2] * fade - cx * (w2 - wbar)
    tc3 = P[P_S3] * taud + P[P_B3] * fade - cx * (w3 - wbar)
    i1 = min(max(tc1 / kt, -imax), imax)
    i2 = min(max(tc2 / kt, -imax), imax)
    i3 = min(max(tc3 / kt, -imax), imax)
    sat = abs(tc1) > kt * imax or abs(tc2) > kt * imax or abs(tc3) > kt * imax
    if sat and ew * taud > 0.0:
        dy[Y_SI] = 0.0
    else:
        dy[Y_SI] = ew
    weps = P[P_WEPS]
    om1 = N * w1
    om2 = N * w2
    om3 = N * w3
    fm1 = N * (P[P_FCM] * math.tanh(om1 / weps) + P[P_FVM] * om1)
    fm2 = N * (P[P_FCM] * math.tanh(om2 / weps) + P[P_FVM] * om2)
    fm3 = N * (P[P_FCM] * math.tanh(om3 / weps) + P[P_FVM] * om3)
    dy[Y_W1] = (N * kt * i1 - t1 - fm1) / P[P_J1]
    dy[Y_W2] = (N * kt * i2 - t2 - fm2) / P[P_J2]
    dy[Y_W3] = (N * kt * i3 - t3 - fm3) / P[P_J3]

    # --- dynamometer torque loop -------------------------------------------------------------
    el = tcmd - y[Y_TL]
    dy[Y_TL] = (tcmd + P[P_KPL] * el + P[P_KIL] * y[Y_ZL] - y[Y_TL]) / P[P_TDYN]
    dy[Y_ZL] = el

    # --- thermal ---------------------------------------------------------------------------
    pg = (abs(F * v) + abs(fp * wp) + P[P_BD] * ktan * aed * aed
          + P[P_FMG] * (abs(fm1 * w1) + abs(fm2 * w2) + abs(fm3 * w3)))
    toil = y[Y_TOIL]
    thous = y[Y_TH]
    goh = P[P_GOH] * (toil - thous)
    gm = P[P_GM]
    r20 = P[P_R20]
    al = P[P_ALCU]
    qm = 0.0
    for k in range(3):
        tm = y[Y_TM1 + k]
        ik = i1 if k == 0 else (i2 if k == 1 else i3)
        pcu = ik * ik * r20 * (1.0 + al * (tm - 20.0))
        hk = gm * (tm - thous)
        qm += hk
        dy[Y_TM1 + k] = (pcu - hk) / P[P_CM]
    dy[Y_TOIL] = (pg - goh) / P[P_COIL]
    dy[Y_TH] = (goh + qm - P[P_GHA] * (thous - P[P_TAMB])) / P[P_CH]

    dy[Y_XH] = dxh
    dy[Y_P1] = 0.0
    dy[Y_P2] = 0.0
    dy[Y_P3] = 0.0

    aux[X_T] = T
    aux[X_F] = F
    aux[X_QDD] = acc
    aux[X_G] = G
    aux[X_DIST] = dist
    aux[X_TLHUB] = tl_hub
    aux[X_I1] = i1
    aux[X_I2] = i2
    aux[X_I3] = i3
    aux[X_TAUD] = taud
    aux[X_TCMD] = tcmd
    aux[X_WREF] = wref
    aux[X_TK] = tk
    aux[X_PG] = pg
    aux[X_TEL] = tel
    aux[X_QREF] = qr
    aux[X_TL] = tL


@njit(cache=True)
def _iwan_clip(y, EC, EP):
    """Update the Iwan play elements to the twist in y (rate-independent hysteresis)."""
    if EC[F_HYST] == 3:
        a = y[Y_A]
        for i in range(3):
            r = EP[F_HYST, 1 + i]
            y[Y_P1 + i] = min(max(y[Y_P1 + i], a - r), a + r)


@njit(cache=True)
def _integrate(y0, tout, P, EC, EP, FA, FB, LT, LV, DN, atol, hmin, hmax):
    """Bogacki-Shampine 3(2) with error control and Hermite dense output at `tout`
    (increasing, tout[0] == 0). Returns (states at tout, aux at tout, accepted, rejected,
    status); status 0 = done, 1 = non-finite state."""
    ny = y0.size
    nout = tout.size
    Y = np.empty((nout, ny))
    A = np.empty((nout, NX))
    y = y0.copy()
    yn = np.empty(ny)
    yt = np.empty(ny)
    k1 = np.empty(ny)
    k2 = np.empty(ny)
    k3 = np.empty(ny)
    k4 = np.empty(ny)
    kd = np.empty(ny)
    aux = np.empty(NX)
    t = 0.0
    _rhs(t, y, P, EC, EP, FA, FB, LT, LV, DN, k1, aux)
    j = 0
    while j < nout and tout[j] <= t:
        for i in range(ny):
            Y[j, i] = y[i]
        for i in range(NX):
            A[j, i] = aux[i]
        j += 1
    tend = tout[nout - 1]
    h = min(hmax, 1e-3)
    nacc = 0
    nrej = 0
    status = 0
    while t < tend:
        last = False
        if t + h >= tend:
            h = tend - t
            last = True
        for i in range(ny):
            yt[i] = y[i] + 0.5 * h * k1[i]
        _rhs(t + 0.5 * h, yt, P, EC, EP, FA, FB, LT, LV, DN, k2, aux)
        for i in range(ny):
            yt[i] = y[i] + 0.75 * h * k2[i]
        _rhs(t + 0.75 * h, yt, P, EC, EP, FA, FB, LT, LV, DN, k3, aux)
        for i in range(ny):
            yn[i] = y[i] + h * (2.0 / 9.0 * k1[i] + 1.0 / 3.0 * k2[i] + 4.0 / 9.0 * k3[i])
        tn = tend if last else t + h
        _rhs(tn, yn, P, EC, EP, FA, FB, LT, LV, DN, k4, aux)
        err = 0.0
        for i in range(ny):
            e = abs(h * (-5.0 / 72.0 * k1[i] + 1.0 / 12.0 * k2[i] + 1.0 / 9.0 * k3[i]
                         - 0.125 * k4[i])) / atol[i]
            if not (e <= err):  # also catches NaN
                err = e
        if not math.isfinite(err):
            if h <= hmin:
                status = 1
                break
            h = max(hmin, 0.2 * h)
            nrej += 1
            continue
        if err <= 1.0 or h <= hmin:
            # dense output on (t, tn]
            while j < nout and tout[j] <= tn:
                th = (tout[j] - t) / h
                for i in range(ny):
                    y0_ = y[i]
                    y1_ = yn[i]
                    yt[i] = ((1.0 - th) * y0_ + th * y1_ + th * (th - 1.0)
                             * ((1.0 - 2.0 * th) * (y1_ - y0_) + (th - 1.0) * h * k1[i]
                                + th * h * k4[i]))
                if EC[F_HYST] == 3:
                    for i in range(3):
                        yt[Y_P1 + i] = y[Y_P1 + i]
                    _iwan_clip(yt, EC, EP)
                _rhs(tout[j], yt, P, EC, EP, FA, FB, LT, LV, DN, kd, aux)
                for i in range(ny):
                    Y[j, i] = yt[i]
                for i in range(NX):
                    A[j, i] = aux[i]
                j += 1
            _iwan_clip(yn, EC, EP)
            for i in range(ny):
                y[i] = yn[i]
                k1[i] = k4[i]
            t = tn
            nacc += 1
            fac = 5.0 if err == 0.0 else min(5.0, max(0.2, 0.9 * err ** (-1.0 / 3.0)))
            h = min(hmax, max(hmin, h * fac))
        else:
            nrej += 1
            h = max(hmin, h * max(0.2, 0.9 * err ** (-1.0 / 3.0)))
    # anything left (only on a failure) is the last state
    while j < nout:
        for i in range(ny):
            Y[j, i] = y[i]
        for i in range(NX):
            A[j, i] = np.nan
        j += 1
    return Y, A, nacc, nrej, status


@njit(cache=True)
def _first_order(x, dt, tau):
    """First-order low-pass of a sequence sampled every dt, exact for a piecewise-linear
    input (first-order hold); starts at rest on x[0]."""
    n = x.size
    y = np.empty(n)
    if n == 0:
        return y
    y[0] = x[0]
    if tau <= 0.0:
        for i in range(n):
            y[i] = x[i]
        return y
    a = math.exp(-dt / tau)
    for i in range(n - 1):
        s = (x[i + 1] - x[i]) / dt
        y[i + 1] = x[i + 1] - tau * s + (y[i] - x[i] + tau * s) * a
    return y


# =============================================================================================
# sensors, arguments, the campaign
# =============================================================================================

def _check_number(name: str, value: Any, lo: float, hi: float, *, lo_open: bool = False,
                  integer: bool = False) -> float:
    if isinstance(value, bool) or not isinstance(value, Real):
        raise ValueError(f"{name} must be a number, got {value!r}")
    x = float(value)
    if not math.isfinite(x):
        raise ValueError(f"{name} must be finite, got {value!r}")
    if integer and not x.is_integer():
        raise ValueError(f"{name} must be a whole number, got {value!r}")
    if (x <= lo if lo_open else x < lo) or x > hi:
        lo_txt = f"({lo}" if lo_open else f"[{lo}"
        raise ValueError(f"{name} must be in {lo_txt}, {hi}], got {value!r}")
    return x


_SENSOR_RANGES: dict[str, tuple[float, float, bool, bool]] = {
    # field: (low, high, low bound open, integer)
    "sample_rate_hz": (10.0, 1000.0, False, False),
    "encoder_res_deg": (0.0, 1.0, True, False),
    "torque_noise": (0.0, 1e4, False, False),
    "torque_lag_s": (0.0, 0.5, False, False),
    "torque_adc_step": (0.0, 1e3, False, False),
    "load_noise": (0.0, 1e4, False, False),
    "load_adc_step": (0.0, 1e3, False, False),
    "motor_encoder_counts": (64.0, float(2 ** 28), False, True),
    "current_noise": (0.0, 10.0, False, False),
    "current_step": (0.0, 1.0, False, False),
    "speed_noise": (0.0, 100.0, False, False),
    "temp_noise": (0.0, 5.0, False, False),
    "temp_res": (0.0, 5.0, False, False),
    "qd_window_s": (0.002, 1.0, False, False),
    "pressure_noise": (0.0, 1e6, False, False),
    "bend_noise": (0.0, 1e5, False, False),
    "shear_noise": (0.0, 1e5, False, False),
}


@dataclass
class SensorSpec:
    """What the bench's sensors resolve; everything here is stated in the run's metadata.

    sample_rate_hz: the logged rate [Hz], 10 ... 1000. encoder_res_deg: output encoder step
    [deg]. torque_noise [N m sd], torque_lag_s [s, stated pure lag], torque_adc_step [N m]:
    the output torque transducer. load_noise, load_adc_step [N m]: the dynamometer's load
    cell. motor_encoder_counts: counts per motor revolution. current_noise, current_step
    [A]; speed_noise [rad/s, motor side]; temp_noise, temp_res [C]; qd_window_s [s]: the
    PLC's differencing window for the output velocity; pressure_noise [Pa], bend_noise
    [N m], shear_noise [N]: the hydraulic channels."""

    sample_rate_hz: float = 100.0
    encoder_res_deg: float = 0.01
    torque_noise: float = 150.0
    torque_lag_s: float = 0.0
    torque_adc_step: float = 5.0
    load_noise: float = 100.0
    load_adc_step: float = 5.0
    motor_encoder_counts: int = 16384
    current_noise: float = 0.01
    current_step: float = 0.001
    speed_noise: float = 0.02
    temp_noise: float = 0.03
    temp_res: float = 0.1
    qd_window_s: float = 0.1
    pressure_noise: float = 5e3
    bend_noise: float = 100.0
    shear_noise: float = 100.0

    def __post_init__(self) -> None:
        for f in fields(self):
            lo, hi, lo_open, integer = _SENSOR_RANGES[f.name]
            _check_number(f.name, getattr(self, f.name), lo, hi, lo_open=lo_open,
                          integer=integer)

    def metadata(self) -> dict[str, dict[str, float]]:
        """The run-format `sensors` block: per channel resolution, noise_sd, lag_s."""
        res_q = math.radians(self.encoder_res_deg)
        res_u = 2.0 * math.pi / (float(self.motor_encoder_counts) * REDUCTION) / 3.0

        def ch(res: float = 0.0, sd: float = 0.0, lag: float = 0.0) -> dict[str, float]:
            return {"resolution": float(res), "noise_sd": float(sd), "lag_s": float(lag)}

        out = {
            "q": ch(res_q),
            "qd": ch(res_q / self.qd_window_s, 0.0, self.qd_window_s / 2.0),
            "u": ch(res_u),
            "ud": ch(0.0, self.speed_noise / REDUCTION / math.sqrt(3.0)),
            "torsion": ch(res_q),
            "torque": ch(self.torque_adc_step, self.torque_noise, self.torque_lag_s),
            "torque_load": ch(self.load_adc_step, self.load_noise),
            "torque_cmd": ch(),
            "temp_joint": ch(self.temp_res, self.temp_noise),
            "p_hyd": ch(0.0, self.pressure_noise),
            "m_bend": ch(0.0, self.bend_noise),
            "f_shear": ch(0.0, self.shear_noise),
        }
        for k in (1, 2, 3):
            out[f"i_m{k}"] = ch(self.current_step, self.current_noise)
            out[f"w_m{k}"] = ch(0.0, self.speed_noise)
            out[f"temp_m{k}"] = ch(self.temp_res, self.temp_noise)
        return out


@dataclass
class RigRun:
    """One simulated run: `samples` and `meta` in the run format, `truth` (true twist
    [rad], torque [N m] and more on the same sample times) and `params` (the campaign
    machine, the unstated imperfections, the effects applied, solver statistics)."""

    samples: pd.DataFrame
    meta: dict[str, Any]
    truth: pd.DataFrame
    params: dict[str, Any]


def _clipped_normal(rng: np.random.Generator, mean: float, sd: float, lo: float,
                    hi: float) -> float:
    return float(min(max(rng.normal(mean, sd), lo), hi))


@lru_cache(maxsize=64)
def _campaign(seed: int) -> dict[str, Any]:
    """The campaign's machine and unstated imperfections, drawn from `seed` alone."""
    rng = np.random.default_rng(np.random.SeedSequence([int(seed), 0x7147]))
    eq4 = {
        "I": _clipped_normal(rng, 6685.166, 25.0, 6599.640, 6753.321),
        "mr_x": _clipped_normal(rng, 20.779, 0.5, 19.302, 22.305),
        "mr_y": _clipped_normal(rng, -34.543, 1.0, -38.549, -30.420),
        "f_v": _clipped_normal(rng, 8683.272, 6.0, 8663.980, 8702.206),
        "f_c": _clipped_normal(rng, 2352.660, 6.0, 2332.964, 2372.455),
    }
    k0 = 1.2e7 * _clipped_normal(rng, 1.0, 0.03, 0.94, 1.06)
    hard = 0.06 * _clipped_normal(rng, 1.0, 0.2, 0.6, 1.4)
    k_mesh = [150.0 * _clipped_normal(rng, 1.0, 0.03, 0.94, 1.06) for _ in range(3)]
    j_m = [1.2e-3 * _clipped_normal(rng, 1.0, 0.02, 0.96, 1.04) for _ in range(3)]
    share = np.array([_clipped_normal(rng, 1.0, 0.01, 0.97, 1.03) for _ in range(3)])
    share = share / share.sum()
    machine = {
        "eq4": eq4,
        "k0": k0,
        "k3": hard * k0 / 0.01 ** 2,
        "hardening_at_0.01rad": hard,
        "beta_d": 8e-3,
        "k_mesh_first_stage": k_mesh,
        "beta_mesh": 4e-3,
        "J_motor": j_m,
        "J_first_stage": 0.02,
        "n1": N1,
        "n2": N2,
        "first_stage_loss": 0.03,
        "first_stage_viscous_out": 2e4,
        "k_t": 1.8,
        "i_max": 6.0,
        "R20": 0.9,
        "motor_coulomb": 0.08,
        "motor_viscous": 1e-4,
        "speed_kp": 0.25,
        "speed_ki": 3.0,
        "position_kp": 6.0,
        "cross_coupling": 0.06,
        "share": share.tolist(),
        "bias": [0.8, -0.4, -0.4],
        "bias_fade": 6.0,
        "dyn_tau": 0.01,
        "dyn_kp": 1.0,
        "dyn_ki": 8.0,
        "C_oil": 3e4,
        "C_housing": 3e5,
        "G_oil_housing": 60.0,
        "G_housing_ambient": 25.0,
        "T_ambient": _clipped_normal(rng, 20.0, 1.5, 16.0, 25.0),
        "C_winding": 800.0,
        "G_winding": 1.5,
        "v_window": 2e-5,
        "tau_stick": 5e-3,
        "p_hyd": 2.9e6 * _clipped_normal(rng, 1.0, 0.02, 0.95, 1.05),
        "cyl_area": 0.0314,
        "cyl_arm": 0.55,
    }
    k_mesh_out = 3.0 * np.mean(k_mesh) * N2 ** 2
    machine["stiffness"] = 1.0 / (1.0 / k0 + 1.0 / k_mesh_out)
    unstated = {
        "torque_zero_offset": float(rng.normal(0.0, 40.0)),
        "bend_crosstalk": _clipped_normal(rng, 0.0015, 0.00045, 0.0005, 0.003),
        "torque_thermal_zero": _clipped_normal(rng, 1.5, 0.45, 0.5, 2.5),
        "torque_thermal_ref_c": 25.0,
        "torque_amp_tau_s": _clipped_normal(rng, 0.004, 0.0008, 0.002, 0.006),
        "encoder_interp_amp_rad": math.radians(0.0008) * _clipped_normal(rng, 1.0, 0.2, 0.6, 1.4),
        "encoder_interp_phase": float(rng.uniform(0.0, 2.0 * math.pi)),
        "encoder_lines": 2048,
    }
    return {"machine": machine, "unstated": unstated}


def _effect_tables(effects: dict[str, dict], machine: dict) -> tuple[np.ndarray, np.ndarray,
                                                                     dict[str, dict]]:
    """Codes and parameters of the physical effects for the kernel (reading effects stay 0)
    and a readable record of every effect applied (sizes at its scale)."""
    EC = np.zeros(13, dtype=np.int64)
    EP = np.zeros((13, 8))
    rec: dict[str, dict] = {}
    I = machine["eq4"]["I"]
    for name, spec in effects.items():
        form = spec["form"]
        s = float(spec["scale"])
        if s == 0.0:
            continue
        fam = _FAMILIES.index(name)
        code = EFFECT_FORMS[name].index(form) + 1
        size: dict[str, Any] = {}
        if name == "stribeck":
            EP[fam, 0], EP[fam, 1] = 400.0 * s, 5e-3
            size = {"dS_Nm": 400.0 * s, "v_s": 5e-3}
        elif name == "load_dependent_friction":
            if form == "coulomb_linear":
                EP[fam, 0] = 0.003 * s
            elif form == "coulomb_viscous":
                EP[fam, 0] = 0.12 * s
            elif form == "power_flow":
                EP[fam, 0], EP[fam, 1] = 0.004 * s, 0.0015 * s
            else:
                EP[fam, 0] = 0.003 * s
            size = {"coef": EP[fam, :2].tolist()}
        elif name == "temperature_friction":
            if form == "viscous_exponential":
                EP[fam, 0], EP[fam, 2] = 0.03 * s, 2.3
            elif form == "coulomb_additive":
                EP[fam, 0] = 10.0 * s
            else:
                EP[fam, 0] = 0.004 * s
            EP[fam, 1] = THETA_REF
            size = {"coef": EP[fam, 0], "theta_ref_c": THETA_REF}
        elif name == "gear_ripple":
            amp = 250.0 * s if form in ("output_torque", "load_modulated") else 2.5e-5 * s
            EP[fam, 0], EP[fam, 1], EP[fam, 2], EP[fam, 3] = amp, MESH_Z, 0.4, 1.9
            size = {"amplitude": amp, "cycles_per_rev": MESH_Z if form != "input_shaft_kinematic"
                    else 2.0}
        elif name == "hysteresis":
            if form == "bouc_wen_n1":
                EP[fam, 0], EP[fam, 1], EP[fam, 2] = 1.5e6 * s, 2500.0, 2500.0
            elif form == "bouc_wen_n2":
                EP[fam, 0], EP[fam, 1], EP[fam, 2] = 1.5e6 * s, 1.5e7, 1.0e7
            elif form == "iwan":
                for i, r in enumerate((0.6e-4, 1.2e-4, 2.4e-4)):
                    EP[fam, 1 + i] = r
                    EP[fam, 4 + i] = 100.0 * s / r
            else:
                EP[fam, 0], EP[fam, 1] = 6e5 * s, 1.5
            size = {"params": EP[fam].tolist(), "loop_half_height_Nm": 300.0 * s}
        elif name == "backlash":
            EP[fam, 0] = 2.5e-5 * s
            size = {"half_gap_rad": 2.5e-5 * s}
        elif name == "asymmetric_friction":
            if form == "coulomb":
                EP[fam, 0] = 200.0 * s
            elif form == "viscous":
                EP[fam, 1] = 1.0 + 0.8 * s
            else:
                EP[fam, 0], EP[fam, 1] = 150.0 * s, 1.0 + 0.4 * s
            size = {"coulomb_shift_Nm": EP[fam, 0], "viscous_ratio": EP[fam, 1]}
        elif name == "periodic_disturbance":
            EP[fam, 0] = (200.0 if form == "two_tone" else 300.0) * s
            size = {"amplitude_Nm": EP[fam, 0]}
        elif name == "position_stiffness":
            EP[fam, 0] = 0.004 * s
            size = {"relative_amplitude": 0.004 * s}
        elif name == "second_resonance":
            # the appendage's inertia I2 grows with s. link_mode and loading_flange: a spring
            # tuned to a fixed f2 (the coupling grows with I2); loading_flange also moves a
            # growing share of the load, min(1, mu(s)/mu(1)), onto the appendage.
            # sensor_on_link: a spring of fixed stiffness (f2 at s = 1), so the appendage's
            # deflection, which the encoder reads, vanishes as s -> 0.
            def mu(x: float) -> float:
                return RES2_MU * x / (1.0 + RES2_MU * x)
            f1 = {"link_mode": 9.0, "loading_flange": 12.0, "sensor_on_link": 7.0}[form]
            i2 = mu(s) * I
            if form == "sensor_on_link":
                k2 = min(mu(1.0) * I * (2.0 * math.pi * f1) ** 2,
                         i2 * (2.0 * math.pi * RES2_FMAX) ** 2)
            else:
                k2 = i2 * (2.0 * math.pi * f1) ** 2
            w2 = math.sqrt(k2 / i2)
            share = min(1.0, mu(s) / mu(1.0)) if form == "loading_flange" else 0.0
            EP[fam, 0], EP[fam, 1], EP[fam, 2], EP[fam, 3] = i2, k2, 2.0 * RES2_ZETA * i2 * w2, share
            size = {"I2": i2, "k2": k2, "f2_hz": w2 / (2.0 * math.pi), "zeta": RES2_ZETA,
                    "load_share_on_appendage": share}
        elif name == "torque_offset":
            size = {"size_Nm": {"constant": 250.0, "linear_drift": 300.0, "warmup_drift": 300.0,
                                "random_walk": 250.0}[form] * s}
        elif name == "time_delay":
            lag = (10e-3 if form.startswith("torque") else 1e-3) * s
            size = {"lag_s": lag}
        elif name == "sensor_drift":
            size = {"size": (3e-5 if form == "encoder_linear" else 300.0) * s}
        if name not in READING_EFFECTS:
            EC[fam] = code
        rec[name] = {"form": form, "scale": s, **size}
    return EC, EP, rec


def _validate_effects(effects: Any) -> dict[str, dict]:
    if effects is None:
        return {}
    if not isinstance(effects, dict):
        raise ValueError(f"effects must be a dict {{name: {{'form', 'scale'}}}}, got {effects!r}")
    out: dict[str, dict] = {}
    for name, spec in effects.items():
        if name not in EFFECT_FORMS:
            raise ValueError(f"effects: unknown effect {name!r}; known: {sorted(EFFECT_FORMS)}")
        if not isinstance(spec, dict) or set(spec) != {"form", "scale"}:
            raise ValueError(f"effects[{name!r}] must be {{'form': ..., 'scale': ...}}, "
                             f"got {spec!r}")
        if spec["form"] not in EFFECT_FORMS[name]:
            raise ValueError(f"effects[{name!r}] form {spec['form']!r} unknown; "
                             f"forms: {EFFECT_FORMS[name]}")
        s = spec["scale"]
        if isinstance(s, bool) or not isinstance(s, Real) or not math.isfinite(float(s)):
            raise ValueError(f"effects[{name!r}] scale must be a finite number, got {s!r}")
        if s < 0.0:
            raise ValueError(f"effects[{name!r}] scale must be >= 0, got {s!r}")
        if s > SCALE_MAX:
            raise ValueError(f"effects[{name!r}] scale {s!r} above SCALE_MAX = {SCALE_MAX}")
        out[name] = {"form": spec["form"], "scale": float(s)}
    return out


def _is_int(x: Any) -> bool:
    return isinstance(x, Integral) and not isinstance(x, bool)


def _schedule(scheme: int) -> tuple[float, np.ndarray, np.ndarray, list[tuple[float, str]]]:
    """Duration [s], the load set point's breakpoints (times, N m) and the phase changes."""
    if scheme == 1:
        lt = np.array([0.0, 4.0, 34.0, 36.0, 66.0, 70.0])
        lv = np.array([0.0, 0.0, T_RATED, T_RATED, 0.0, 0.0])
        phases = [(0.0, "idle"), (4.0, "load"), (34.0, "hold"), (36.0, "unload"), (66.0, "idle")]
        return 70.0, lt, lv, phases
    lt_l = [0.0, 4.0]
    lv_l = [0.0, 0.0]
    phases = [(0.0, "idle")]
    t = 4.0
    for k in range(1, 13):
        phases.append((t, "load"))
        lt_l += [t + 1.0, t + 3.0]
        lv_l += [10e3 * k, 10e3 * k]
        phases.append((t + 1.0, "hold"))
        t += 3.0
    phases.append((t, "unload"))
    lt_l += [t + 12.0, t + 16.0]
    lv_l += [0.0, 0.0]
    phases.append((t + 12.0, "idle"))
    return t + 16.0, np.array(lt_l), np.array(lv_l), phases


def _dyn_ripple_knots(rng: np.random.Generator, duration: float) -> np.ndarray:
    """Knots of the dynamometer's torque ripple for a run of `duration` s (see DYN_RIPPLE_*)."""
    nk = int(math.ceil(duration * DYN_RIPPLE_RATE)) + 4
    nfft = 1 << int(math.ceil(math.log2(nk + 64)))
    spec = np.fft.rfft(rng.normal(0.0, 1.0, nfft))
    f = np.fft.rfftfreq(nfft, 1.0 / DYN_RIPPLE_RATE)
    spec[(f < DYN_RIPPLE_BAND[0]) | (f > DYN_RIPPLE_BAND[1])] = 0.0
    x = np.fft.irfft(spec, nfft)[:nk]
    x *= DYN_RIPPLE_RMS / np.sqrt(np.mean(x ** 2))
    tk = np.arange(nk) / DYN_RIPPLE_RATE
    x *= np.clip(tk / 0.5, 0.0, 1.0) ** 2
    return np.concatenate(([x[0]], x))


def _quantise(x: np.ndarray, step: float) -> np.ndarray:
    return np.round(x / step) * step if step > 0.0 else x


def _lagged(x: np.ndarray, ti: np.ndarray, ts: np.ndarray, lag: float) -> np.ndarray:
    """x (on the internal grid ti) read at ts - lag; before the start, the initial value."""
    if lag == 0.0:
        return np.interp(ts, ti, x)
    return np.interp(ts - lag, ti, x, left=x[0])


def simulate_run(scheme: int, motor_speed_rpm: float | None, direction: int,
                 temp_joint_c: float, effects: dict[str, dict] | None = None, *,
                 sensors: SensorSpec | None = None, periods: int = 3, seed: int,
                 run: int) -> RigRun:
    """Simulate one run of the bench: scheme 1 or 2 at `motor_speed_rpm` (0, 3000], or
    scheme 3 (Eq. 12, `periods` periods, motor_speed_rpm None); `direction` +1/-1; the
    gearbox at `temp_joint_c` [15, 60] C at the start; `effects` {name: {"form", "scale"}}.
    `seed` draws the campaign's machine, (seed, run) the run's noise. Deterministic."""
    # --- arguments -------------------------------------------------------------------------
    if not _is_int(scheme) or scheme not in (1, 2, 3):
        raise ValueError(f"scheme must be 1, 2 or 3, got {scheme!r}")
    if scheme == 3:
        if motor_speed_rpm is not None:
            raise ValueError(f"motor_speed_rpm must be None for scheme 3, got {motor_speed_rpm!r}")
    else:
        if motor_speed_rpm is None:
            raise ValueError("motor_speed_rpm is required for schemes 1 and 2")
        _check_number("motor_speed_rpm", motor_speed_rpm, 0.0, 3000.0, lo_open=True)
    if not _is_int(direction) or direction not in (1, -1):
        raise ValueError(f"direction must be +1 or -1, got {direction!r}")
    _check_number("temp_joint_c", temp_joint_c, 15.0, 60.0)
    eff = _validate_effects(effects)
    if sensors is None:
        sensors = SensorSpec()
    elif not isinstance(sensors, SensorSpec):
        raise ValueError(f"sensors must be a SensorSpec, got {sensors!r}")
    else:
        sensors.__post_init__()  # a field may have been changed since it was made
    if not _is_int(periods) or not 1 <= periods <= 20:
        raise ValueError(f"periods must be a whole number in [1, 20], got {periods!r}")
    if not _is_int(seed) or seed < 0:
        raise ValueError(f"seed must be a whole number >= 0, got {seed!r}")
    if not _is_int(run) or run < 0:
        raise ValueError(f"run must be a whole number >= 0, got {run!r}")
    scheme, direction, seed, run, periods = int(scheme), int(direction), int(seed), int(run), int(periods)
    temp0 = float(temp_joint_c)

    camp = _campaign(seed)
    machine, unstated = camp["machine"], camp["unstated"]
    eq4 = machine["eq4"]
    EC, EP, eff_rec = _effect_tables(eff, machine)

    # --- schedule ----------------------------------------------------------------------------
    fa, fb = fourier_coefficients()
    wf = 2.0 * math.pi / FOURIER_PERIOD_S
    if scheme == 3:
        duration = periods * FOURIER_PERIOD_S
        lt = np.array([0.0, duration])
        lv = np.zeros(2)
        phases = [(0.0, "excite")]
        wcmd = 0.0
    else:
        duration, lt, lv, phases = _schedule(scheme)
        wcmd = float(motor_speed_rpm) * 2.0 * math.pi / 60.0 / REDUCTION

    # --- parameters ---------------------------------------------------------------------------
    n = REDUCTION
    P = np.zeros(NP)
    i2 = EP[F_RES2, 0] if EC[F_RES2] else 0.0
    P[P_IHUB] = eq4["I"] - i2
    P[P_MRX], P[P_MRY], P[P_FV], P[P_FC] = eq4["mr_x"], eq4["mr_y"], eq4["f_v"], eq4["f_c"]
    P[P_GRAV] = 9.81
    P[P_K0], P[P_K3], P[P_BD] = machine["k0"], machine["k3"], machine["beta_d"]
    for k, idx in enumerate((P_KM1, P_KM2, P_KM3)):
        P[idx] = machine["k_mesh_first_stage"][k] * N2 ** 2
    P[P_BM] = machine["beta_mesh"]
    for k, idx in enumerate((P_J1, P_J2, P_J3)):
        P[idx] = machine["J_motor"][k] * n ** 2
    P[P_JP] = machine["J_first_stage"] * N2 ** 2
    P[P_ETA] = machine["first_stage_loss"]
    P[P_CP] = machine["first_stage_viscous_out"]
    P[P_EPSW] = 1e-4
    P[P_N], P[P_N2] = n, N2
    P[P_KT], P[P_IMAX], P[P_R20], P[P_ALCU] = machine["k_t"], machine["i_max"], machine["R20"], 0.00393
    P[P_FCM], P[P_FVM], P[P_WEPS] = machine["motor_coulomb"], machine["motor_viscous"], 0.5
    P[P_KP], P[P_KI] = machine["speed_kp"], machine["speed_ki"]
    P[P_KPOS], P[P_CX] = machine["position_kp"], machine["cross_coupling"]
    P[P_JFF] = sum(machine["J_motor"]) + machine["J_first_stage"] / N1 ** 2
    P[P_S1], P[P_S2], P[P_S3] = machine["share"]
    P[P_B1], P[P_B2], P[P_B3] = machine["bias"]
    P[P_BFADE] = machine["bias_fade"]
    P[P_TDYN], P[P_KPL], P[P_KIL] = machine["dyn_tau"], machine["dyn_kp"], machine["dyn_ki"]
    P[P_COIL], P[P_CH] = machine["C_oil"], machine["C_housing"]
    P[P_GOH], P[P_GHA], P[P_TAMB] = (machine["G_oil_housing"], machine["G_housing_ambient"],
                                     machine["T_ambient"])
    P[P_CM], P[P_GM], P[P_FMG] = machine["C_winding"], machine["G_winding"], 0.5
    P[P_VWIN], P[P_TAUS] = machine["v_window"], machine["tau_stick"]
    P[P_SCHEME], P[P_DIR], P[P_WCMD], P[P_TRAMP] = float(scheme), float(direction), wcmd, 1.0
    P[P_WF] = wf
    P[P_Q0] = float(sum(fb[l] / (wf * (l + 1)) for l in range(5)))

    # --- run-level randomness (fixed streams per channel) ---------------------------------
    ss = np.random.SeedSequence([seed, run, 0x5E75])
    streams = [np.random.default_rng(c) for c in ss.spawn(24)]

    y0 = np.zeros(NY)
    for k, idx in enumerate((Y_E1, Y_E2, Y_E3)):
        y0[idx] = n * machine["bias"][k] / P[P_KM1 + k]  # bias preload at rest
    y0[Y_TOIL] = temp0
    y0[Y_TH] = temp0
    wind0 = streams[0].normal(0.0, 0.5, 3)
    for k in range(3):
        y0[Y_TM1 + k] = temp0 + float(wind0[k])

    atol = np.empty(NY)
    atol[:] = 1e-6
    atol[Y_Q] = 1e-8
    atol[Y_V] = 2e-8
    atol[Y_A] = 5e-9
    atol[Y_WP] = 2e-8
    atol[Y_E1:Y_E3 + 1] = 2e-10
    atol[Y_W1:Y_W3 + 1] = 2e-8
    atol[Y_SI] = 1e-8
    atol[Y_TL] = 0.05
    atol[Y_ZL] = 0.01
    atol[Y_TOIL:Y_TM3 + 1] = 1e-4
    atol[Y_XH] = 2e-9
    atol[Y_P1:Y_P3 + 1] = 1.0
    atol[Y_R2] = 5e-9
    atol[Y_V2] = 2e-8

    # --- integrate on the internal grid ---------------------------------------------------
    fs = float(sensors.sample_rate_hz)
    ns = int(math.floor(duration * fs + 1e-9)) + 1
    m = int(math.ceil(1000.0 / fs - 1e-9))
    fi = fs * m
    ni = (ns - 1) * m + 1
    ti = np.arange(ni) / fi
    ts = ti[::m]
    DN = _dyn_ripple_knots(streams[21], duration)
    Y, A, nacc, nrej, status = _integrate(y0, ti, P, EC, EP, fa, fb, lt, lv, DN, atol, 1e-6, 0.02)
    if status != 0 or not np.all(np.isfinite(Y)) or not np.all(np.isfinite(A)):
        raise RuntimeError("rig_t: the integration diverged (non-finite state)")

    # --- truth on the sample times ---------------------------------------------------------
    Ys, As = Y[::m], A[::m]
    q_t = Ys[:, Y_Q]
    u_k = [Ys[:, Y_Q] + Ys[:, Y_A] + Ys[:, idx] for idx in (Y_E1, Y_E2, Y_E3)]
    u_t = (u_k[0] + u_k[1] + u_k[2]) / 3.0
    sg = np.where(np.abs(Ys[:, Y_V]) > machine["v_window"], np.sign(Ys[:, Y_V]), 0.0)
    eq4_rhs = (eq4["I"] * As[:, X_QDD] + 9.81 * (eq4["mr_x"] * np.sin(q_t) + eq4["mr_y"] * np.cos(q_t))
               + eq4["f_v"] * Ys[:, Y_V] + eq4["f_c"] * sg)
    truth = pd.DataFrame({
        "t": ts,
        "twist": u_t - q_t,
        "torque": As[:, X_T],
        "q": q_t,
        "qd": Ys[:, Y_V],
        "qdd": As[:, X_QDD],
        "u": u_t,
        "torque_load": As[:, X_TL],
        "torque_cmd": As[:, X_TCMD],
        "friction": As[:, X_F],
        "gravity": As[:, X_G],
        "disturbance": As[:, X_DIST],
        "balance_residual": As[:, X_T] - As[:, X_TL] - eq4_rhs,
        "temp_joint": Ys[:, Y_TOIL],
        "i_m1": As[:, X_I1],
        "i_m2": As[:, X_I2],
        "i_m3": As[:, X_I3],
    })
    if EC[F_RES2]:
        truth["q_link"] = q_t + Ys[:, Y_R2]

    # --- sensors --------------------------------------------------------------------------
    sp = sensors
    rd = {name: spec for name, spec in eff.items() if spec["scale"] > 0.0 and name in READING_EFFECTS}

    def lag_of(form: str) -> float:
        e = rd.get("time_delay")
        if e is None or e["form"] != form:
            return 0.0
        return (10e-3 if form.startswith("torque") else 1e-3) * e["scale"]

    dti = 1.0 / fi
    # output encoder (on the appendage for second_resonance/sensor_on_link)
    q_phys = Y[:, Y_Q] + (Y[:, Y_R2] if EC[F_RES2] == 3 else 0.0)
    res_q = math.radians(sp.encoder_res_deg)
    q_lag = lag_of("position_pure")
    ea, eph, el = (unstated["encoder_interp_amp_rad"], unstated["encoder_interp_phase"],
                   unstated["encoder_lines"])
    drift_q = np.zeros(ns)
    if "sensor_drift" in rd and rd["sensor_drift"]["form"] == "encoder_linear":
        drift_q = 3e-5 * rd["sensor_drift"]["scale"] * ts / 60.0

    def encoder(tq: np.ndarray, drift: np.ndarray) -> np.ndarray:
        qq = np.interp(tq - q_lag, ti, q_phys, left=q_phys[0])
        return _quantise(qq + ea * np.sin(el * qq + eph) + drift, res_q)

    q_meas = encoder(ts, drift_q)
    drift_q_back = np.interp(ts - sp.qd_window_s, ts, drift_q, left=drift_q[0])
    q_back = encoder(np.maximum(ts - sp.qd_window_s, 0.0), drift_q_back)
    qd_meas = (q_meas - q_back) / sp.qd_window_s

    # motor encoders and drives
    u_lag = lag_of("motor_pure")
    res_m = 2.0 * math.pi / float(sp.motor_encoder_counts)
    u_meas = np.zeros(ns)
    w_meas = []
    for k, idx in enumerate((Y_E1, Y_E2, Y_E3)):
        uk = Y[:, Y_Q] + Y[:, Y_A] + Y[:, idx]
        ang = _lagged(uk * n, ti, ts, u_lag)
        u_meas += _quantise(ang, res_m) / n / 3.0
        wk = _lagged(Y[:, Y_W1 + k] * n, ti, ts, u_lag)
        w_meas.append(wk + streams[1 + k].normal(0.0, 1.0, ns) * sp.speed_noise)
    ud_meas = (w_meas[0] + w_meas[1] + w_meas[2]) / 3.0 / n

    # torque transducer
    T_int = A[:, X_T]
    T_f = _first_order(T_int, dti, unstated["torque_amp_tau_s"])
    extra_fo = lag_of("torque_first_order")
    if extra_fo > 0.0:
        T_f = _first_order(T_f, dti, extra_fo)
    T_read = _lagged(T_f, ti, ts, sp.torque_lag_s + lag_of("torque_pure"))
    temp_oil = Ys[:, Y_TOIL]
    m_bend_true = machine["p_hyd"] * machine["cyl_area"] * machine["cyl_arm"]
    f_shear_true = machine["p_hyd"] * machine["cyl_area"]
    offset = (unstated["torque_zero_offset"] + unstated["bend_crosstalk"] * m_bend_true
              + unstated["torque_thermal_zero"] * (temp_oil - unstated["torque_thermal_ref_c"]))
    e = rd.get("torque_offset")
    if e is not None:
        s = e["scale"]
        if e["form"] == "constant":
            offset = offset + 250.0 * s
        elif e["form"] == "linear_drift":
            offset = offset + 300.0 * s * ts / 60.0
        elif e["form"] == "warmup_drift":
            offset = offset + 300.0 * s * (1.0 - np.exp(-ts / 20.0))
        else:
            rw_rng = streams[20]
            inc = rw_rng.normal(0.0, 1.0, ns) * np.sqrt(np.diff(ts, prepend=0.0) / 60.0)
            inc[0] = 0.0
            offset = offset + 250.0 * s * np.cumsum(inc)
    torque_meas = _quantise(T_read + offset + streams[4].normal(0.0, 1.0, ns) * sp.torque_noise,
                            sp.torque_adc_step)

    # load cell
    tl = As[:, X_TL].copy()
    e = rd.get("sensor_drift")
    if e is not None and e["form"] == "load_cell_linear":
        tl = tl + 300.0 * e["scale"] * ts / 60.0
    elif e is not None and e["form"] == "load_cell_warmup":
        tl = tl + 300.0 * e["scale"] * (1.0 - np.exp(-ts / 25.0))
    load_meas = _quantise(tl + streams[5].normal(0.0, 1.0, ns) * sp.load_noise, sp.load_adc_step)

    cur = [_lagged(A[:, X_I1 + k], ti, ts, 0.0) for k in range(3)]
    i_meas = [_quantise(cur[k] + streams[6 + k].normal(0.0, 1.0, ns) * sp.current_noise,
                        sp.current_step) for k in range(3)]
    temps_m = [_quantise(Ys[:, Y_TM1 + k] + streams[9 + k].normal(0.0, 1.0, ns) * sp.temp_noise,
                         sp.temp_res) for k in range(3)]
    temp_j = _quantise(temp_oil + streams[12].normal(0.0, 1.0, ns) * sp.temp_noise, sp.temp_res)
    p_meas = machine["p_hyd"] + streams[13].normal(0.0, 1.0, ns) * sp.pressure_noise
    mb_meas = m_bend_true + streams[14].normal(0.0, 1.0, ns) * sp.bend_noise
    fsh_meas = f_shear_true + streams[15].normal(0.0, 1.0, ns) * sp.shear_noise

    ph_t = np.array([p[0] for p in phases])
    ph_n = np.array([p[1] for p in phases], dtype=object)
    phase = ph_n[np.searchsorted(ph_t, ts + 1e-9, side="right") - 1]

    samples = pd.DataFrame({
        "t": ts,
        "q": q_meas,
        "qd": qd_meas,
        "u": u_meas,
        "ud": ud_meas,
        "torsion": q_meas - u_meas,
        "torque": torque_meas,
        "torque_load": load_meas,
        "torque_cmd": As[:, X_TCMD],
        "i_m1": i_meas[0], "i_m2": i_meas[1], "i_m3": i_meas[2],
        "w_m1": w_meas[0], "w_m2": w_meas[1], "w_m3": w_meas[2],
        "temp_m1": temps_m[0], "temp_m2": temps_m[1], "temp_m3": temps_m[2],
        "temp_joint": temp_j,
        "p_hyd": p_meas,
        "m_bend": mb_meas,
        "f_shear": fsh_meas,
        "phase": pd.Series(list(phase), dtype=object),
    })

    minute = 15 * (run % 40)
    meta: dict[str, Any] = {
        "scheme": scheme,
        "motor_speed_rpm": None if scheme == 3 else float(motor_speed_rpm),
        "direction": direction,
        "reduction": REDUCTION,
        "rig": RIG_NAME,
        "source": "emulator",
        "sample_rate_hz": fs,
        "started_at": f"2026-03-{1 + (run // 40) % 28:02d}T{8 + minute // 60:02d}:{minute % 60:02d}:00Z",
        "notes": f"{RIG_NAME}: scheme {scheme}, direction {direction:+d}, "
                 f"joint at {temp0:.1f} C at the start",
        "shear_setpoint_n": float(f_shear_true),
        "bend_setpoint_nm": float(m_bend_true),
        "sensors": sp.metadata(),
    }
    params = {
        "machine": copy.deepcopy(machine),
        "unstated": copy.deepcopy(unstated),
        "effects": eff_rec,
        "scheme": scheme,
        "motor_speed_rpm": meta["motor_speed_rpm"],
        "direction": direction,
        "temp_joint_c": temp0,
        "seed": seed,
        "run": run,
        "solver": {"method": "Bogacki-Shampine 3(2)", "accepted": int(nacc),
                   "rejected": int(nrej), "h_min": 1e-6, "h_max": 0.02,
                   "internal_rate_hz": fi},
    }
    return RigRun(samples=samples, meta=meta, truth=truth, params=params)
